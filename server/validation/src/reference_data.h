// The validation cases' reference data: the CSV files of server/validation/data/, embedded as
// text at build time (cmake/EmbedReferenceData.cmake writes EmbeddedReferenceCsvs()) and parsed
// here into the tables of dysa/validation/validation.h and validation_impact.h. Private to
// dysa_validation (and its tests).
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace dysa {

struct ReferenceCsv {
  std::string_view name;  // the file name without .csv
  std::string_view text;  // the whole file
};
// Every data/*.csv, sorted by name (generated).
const std::vector<ReferenceCsv>& EmbeddedReferenceCsvs();

// The text of the embedded file `name`; throws std::logic_error when there is none.
std::string_view ReferenceCsvText(std::string_view name);

// The rows of a reference CSV: lines that are empty or start with '#' are skipped, the first
// other line is the header and must name exactly `columns`, and every later line holds as many
// decimal numbers, parsed with std::from_chars (correctly rounded: the same double as the
// literal in C++ source). Throws std::runtime_error naming `name` and the line otherwise.
std::vector<std::vector<double>> ParseReferenceCsv(std::string_view text,
                                                   const std::vector<std::string>& columns,
                                                   std::string_view name);

}  // namespace dysa
