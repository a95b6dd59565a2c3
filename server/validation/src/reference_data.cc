#include "reference_data.h"

#include <charconv>
#include <stdexcept>
#include <system_error>

#include "dysa/validation/validation.h"
#include "dysa/validation/validation_impact.h"

namespace dysa {
namespace {

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) {
    s.remove_suffix(1);
  }
  return s;
}

std::vector<std::string_view> SplitFields(std::string_view line) {
  std::vector<std::string_view> fields;
  size_t start = 0;
  while (true) {
    const size_t comma = line.find(',', start);
    fields.push_back(Trim(line.substr(start, comma - start)));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return fields;
}

[[noreturn]] void Fail(std::string_view name, int line, const std::string& what) {
  throw std::runtime_error("reference data " + std::string(name) + ".csv, line " +
                           std::to_string(line) + ": " + what);
}

// The rows of the embedded file `name`, checked to have `columns`.
std::vector<std::vector<double>> Rows(std::string_view name,
                                      const std::vector<std::string>& columns) {
  return ParseReferenceCsv(ReferenceCsvText(name), columns, name);
}

}  // namespace

std::string_view ReferenceCsvText(std::string_view name) {
  for (const ReferenceCsv& file : EmbeddedReferenceCsvs()) {
    if (file.name == name) return file.text;
  }
  throw std::logic_error("no embedded reference data named " + std::string(name));
}

std::vector<std::vector<double>> ParseReferenceCsv(std::string_view text,
                                                   const std::vector<std::string>& columns,
                                                   std::string_view name) {
  std::vector<std::vector<double>> rows;
  bool header = false;
  int number = 0;
  size_t start = 0;
  while (start < text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = Trim(text.substr(start, end - start));
    start = end + 1;
    ++number;
    if (line.empty() || line.front() == '#') continue;
    const std::vector<std::string_view> fields = SplitFields(line);
    if (!header) {
      header = true;
      bool same = fields.size() == columns.size();
      for (size_t c = 0; same && c < columns.size(); ++c) same = fields[c] == columns[c];
      if (!same) Fail(name, number, "the header is not the expected columns");
      continue;
    }
    if (fields.size() != columns.size()) {
      Fail(name, number,
           std::to_string(fields.size()) + " fields, expected " + std::to_string(columns.size()));
    }
    std::vector<double>& row = rows.emplace_back(columns.size());
    for (size_t c = 0; c < columns.size(); ++c) {
      const std::string_view field = fields[c];
      const auto [ptr, error] = std::from_chars(field.data(), field.data() + field.size(), row[c]);
      if (error != std::errc() || ptr != field.data() + field.size() || field.empty()) {
        Fail(name, number,
             "column " + columns[c] + " is not a number: '" + std::string(field) + "'");
      }
    }
  }
  if (!header) Fail(name, number, "no header line");
  return rows;
}

const std::vector<MartinMoyceRow>& MartinMoyce1952Front() {
  static const std::vector<MartinMoyceRow> rows = [] {
    std::vector<MartinMoyceRow> out;
    for (const std::vector<double>& r : Rows("dam_break_martin_moyce_1952_front", {"T", "Z"})) {
      out.push_back({r[0], r[1]});
    }
    return out;
  }();
  return rows;
}

const std::vector<MartinMoyceHeightRow>& MartinMoyce1952ResidualHeight() {
  static const std::vector<MartinMoyceHeightRow> rows = [] {
    std::vector<MartinMoyceHeightRow> out;
    for (const std::vector<double>& r : Rows("dam_break_martin_moyce_1952_height", {"tau", "H"})) {
      out.push_back({r[0], r[1]});
    }
    return out;
  }();
  return rows;
}

const std::vector<GaugeRow>& MarinGaugeHeights() {
  static const std::vector<GaugeRow> rows = [] {
    std::vector<GaugeRow> out;
    for (const std::vector<double>& r :
         Rows("spheric_test2_marin_heights", {"t_s", "H1_m", "H2_m", "H3_m", "H4_m"})) {
      out.push_back({r[0], {r[1], r[2], r[3], r[4]}});
    }
    return out;
  }();
  return rows;
}

}  // namespace dysa
