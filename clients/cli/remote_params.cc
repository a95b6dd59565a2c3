// dysa params, dysa set NAME=VALUE...
#include <ostream>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "dysa/core/params.h"
#include "dysa/core/types.h"
#include "remote_commands.h"
#include "remote_format.h"

namespace dysa::remote {
namespace {

Json ToJson(const std::vector<ParamInfo>& params) {
  Json out = Json::array();
  for (const ParamInfo& p : params) {
    out.push_back({{"name", p.name},
                   {"value", p.value},
                   {"unit", p.unit},
                   {"min", p.min},
                   {"max", p.max},
                   {"default_value", p.default_value},
                   {"integer", p.integer},
                   {"needs_reset", p.needs_reset},
                   {"description", p.description},
                   {"solvers", p.solvers}});
  }
  return out;
}

}  // namespace

void PrintParams(Client& client, bool json, std::ostream& out) {
  const std::vector<ParamInfo> params = client.GetParams();
  if (json) return PrintJson({{"params", ToJson(params)}}, out);
  std::vector<std::vector<std::string>> rows = {
      {"name", "value", "unit", "range", "default", "needs reset", "read by"}};
  for (const ParamInfo& p : params) {
    std::string range = "[";  // "[" + Short(...) draws a false -Wrestrict from GCC 12
    range += Short(p.min) + ", " + Short(p.max) + "]" + (p.integer ? " integer" : "");
    std::string solvers;  // the solvers that read it, "" from an older server
    for (const std::string& s : p.solvers) {
      if (!solvers.empty()) solvers += ", ";
      solvers += s;
    }
    rows.push_back({p.name, Short(p.value), p.unit, range, Short(p.default_value),
                    p.needs_reset ? "yes" : "", solvers});
  }
  PrintTable(rows, {1}, out);
}

std::vector<std::pair<std::string, double>> ParseAssignments(
    const std::vector<std::string>& assignments) {
  std::vector<std::pair<std::string, double>> values;
  std::set<std::string> seen;
  for (const std::string& assignment : assignments) {
    std::pair<std::string, double> parsed;
    try {
      parsed = ParseAssignment(assignment);  // names and ranges are the server's to check
    } catch (const ConfigError& e) {
      throw UsageError(e.what());
    }
    const auto& [name, value] = parsed;
    if (!seen.insert(name).second) throw UsageError(name + ": given more than once");
    values.emplace_back(name, value);
  }
  if (values.empty()) throw UsageError("no NAME=VALUE given");
  return values;
}

void SetParams(Client& client, const std::vector<std::string>& assignments, bool json,
               std::ostream& out) {
  const std::vector<std::pair<std::string, double>> values = ParseAssignments(assignments);
  const UpdateResult r = client.UpdateParams(values);
  if (json) {
    Json changed = Json::object();
    for (const auto& [name, value] : values) {
      changed[name] = value;
      for (const ParamInfo& p : r.params) {
        if (p.name == name) changed[name] = p.value;
      }
    }
    return PrintJson({{"reset", r.reset},
                      {"changed", changed},
                      {"params", ToJson(r.params)},
                      {"status", ToJson(r.status)}},
                     out);
  }
  for (const auto& [name, value] : values) {
    const ParamInfo* info = nullptr;
    for (const ParamInfo& p : r.params) {
      if (p.name == name) info = &p;
    }
    out << name << " = " << Short(info ? info->value : value);
    if (info && !info->unit.empty()) out << " " << info->unit;
    out << "\n";
  }
  out << (r.reset ? "reset: the fluid was re-spawned, now at " + Where(r.status)
                  : "no reset: the simulation carries on at " + Where(r.status))
      << "\n";
}

}  // namespace dysa::remote
