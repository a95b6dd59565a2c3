#include "remote_format.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <ostream>
#include <sstream>
#include <utility>

#include "dysa/codec/frame_codec.h"
#include "remote_commands.h"

namespace dysa::remote {

std::string Fixed(double value, int decimals) {
  std::ostringstream text;
  text << std::fixed << std::setprecision(decimals) << value;
  return text.str();
}

std::string Short(double value) {
  std::ostringstream text;
  text << value;
  return text.str();
}

std::string HumanBytes(double bytes) {
  static constexpr const char* kUnits[] = {"B", "kB", "MB", "GB", "TB"};
  int unit = 0;
  while (std::abs(bytes) >= 1000 && unit < 4) bytes /= 1000, ++unit;
  return Fixed(bytes, unit == 0 ? 0 : 1) + " " + kUnits[unit];
}

std::string DeviceText(const ServerStatus& s) {
  if (s.device.empty()) return "not reported (an older server)";
  if (s.device_memory_bytes == 0) return s.device;
  return s.device + "; " + HumanBytes(double(s.device_memory_bytes)) + " held";
}

void PrintTable(const std::vector<std::vector<std::string>>& rows, const std::set<size_t>& right,
                std::ostream& out) {
  std::vector<size_t> width;
  for (const auto& row : rows) {
    width.resize(std::max(width.size(), row.size()));
    for (size_t c = 0; c < row.size(); ++c) width[c] = std::max(width[c], row[c].size());
  }
  for (const auto& row : rows) {
    std::string line;
    for (size_t c = 0; c < row.size(); ++c) {
      const std::string pad(width[c] - row[c].size(), ' ');
      line += right.count(c) ? pad + row[c] : row[c] + (c + 1 < row.size() ? pad : "");
      if (c + 1 < row.size()) line += "  ";
    }
    while (!line.empty() && line.back() == ' ') line.pop_back();
    out << line << "\n";
  }
}

std::string FieldNames(uint32_t fields) {
  std::string names;
  const std::pair<uint32_t, const char*> all[] = {{codec::kPositions, "positions"},
                                                  {codec::kSpeed, "speed"},
                                                  {codec::kVelocity, "velocity"},
                                                  {codec::kDensity, "density"}};
  for (const auto& [bit, name] : all) {
    if (fields & bit) names += (names.empty() ? "" : ", ") + std::string(name);
  }
  return names;
}

std::string Where(const ServerStatus& s) {
  return "frame " + std::to_string(s.frame) + " (t = " + Fixed(s.time, 4) + " s, step " +
         std::to_string(s.step) + ")";
}

Json ToJson(const ServerStatus& s) {
  Json passes = Json::array();
  for (const PassTiming& p : s.passes) {
    passes.push_back(
        {{"name", p.name}, {"last_ms", p.last_ms}, {"mean_ms", p.mean_ms}, {"calls", p.calls}});
  }
  Json streams = Json::array();
  for (const StreamStatus& t : s.streams) {
    streams.push_back({{"detail", t.detail},
                       {"particles", t.particles},
                       {"bytes_per_second", t.bytes_per_second},
                       {"frames_per_second", t.frames_per_second},
                       {"age_s", t.age_s},
                       {"link_bytes_per_second", t.link_bytes_per_second},
                       {"fps_target", t.fps_target},
                       {"byte_budget", t.byte_budget},
                       {"particle_budget", t.particle_budget}});
  }
  return {{"state", s.state},
          {"step", s.step},
          {"frame", s.frame},
          {"time", s.time},
          {"particles", s.particles},
          {"solver", s.solver},
          {"scene", s.scene},
          {"frames_per_second", s.frames_per_second},
          {"target_frame_rate", s.target_frame_rate},
          {"passes", passes},
          {"subscribers", s.subscribers},
          {"alarm", s.alarm},
          {"warning", s.warning},
          {"history_frames", s.history_frames},
          {"history_bytes", s.history_bytes},
          {"frames_encoded", s.frames_encoded},
          {"state_hash", s.state_hash},
          {"scene_version", s.scene_version},
          {"solver_threads", s.solver_threads},
          {"device", s.device},
          {"device_memory_bytes", s.device_memory_bytes},
          {"streams", streams}};
}

Json ToJson(const ControlResult& r) {
  return {{"status", ToJson(r.status)}, {"reset", r.reset}, {"frames_moved", r.frames_moved}};
}

void PrintJson(const Json& json, std::ostream& out) { out << json.dump(2) << "\n"; }

// Declared in remote_commands.h, for watch and record: the inverse of FieldNames.
uint32_t ParseFields(const std::vector<std::string>& names) {
  uint32_t fields = codec::kPositions;
  for (const std::string& name : names) {
    if (name == "positions") {
      fields |= codec::kPositions;
    } else if (name == "speed") {
      fields |= codec::kSpeed;
    } else if (name == "velocity") {
      fields |= codec::kVelocity;
    } else if (name == "density") {
      fields |= codec::kDensity;
    } else {
      throw UsageError("--fields: unknown field '" + name +
                       "' (positions, speed, velocity, density)");
    }
  }
  return fields;
}

}  // namespace dysa::remote
