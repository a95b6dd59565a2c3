// libFuzzer target for the --set NAME=VALUE parsers (server/core/src/params.cc): the input is one
// assignment, as `dysa-server --set`, `dysa run --set` or `dysa set` take it.
//
// Checked, besides no crash, sanitizer report or hang:
//   - ParseAssignment returns (name, value) or throws ConfigError and nothing else; a value it
//     returns is finite and not 0 unless written as a zero; its error names no field exactly
//     when there is no NAME= (an empty name), else the name made safe;
//   - SetParam(params, name, value) with what it returned, and SetParamFromString on the same
//     text, agree: both set the same value or both throw a ConfigError naming a field; SetParam
//     leaves `params` unchanged when it throws; a value set reads back (GetParam) exactly;
//   - every error is bounded and escaped (fuzz_checks.h).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <exception>
#include <optional>
#include <string>
#include <string_view>
#include <typeinfo>
#include <utility>

#include "dysa/core/params.h"
#include "dysa/core/text.h"
#include "dysa/core/types.h"
#include "fuzz_checks.h"

namespace {

constexpr std::string_view kHarness = "param_assignment_fuzzer";

using dysa::fuzz::CheckSafeText;
using dysa::fuzz::Finding;

void CheckError(const dysa::ConfigError& e, std::string_view stage) {
  CheckSafeText(kHarness, std::string(stage) + " error", e.what());
  CheckSafeText(kHarness, std::string(stage) + " error's field", e.field());
}

[[noreturn]] void Unexpected(std::string_view stage) {
  try {
    throw;
  } catch (const std::exception& e) {
    Finding(kHarness, std::string(stage) + " threw " + typeid(e).name() + ": " + e.what());
  } catch (...) {
    Finding(kHarness, std::string(stage) + " threw something that is not a std::exception");
  }
}

bool SameParams(const dysa::Params& a, const dysa::Params& b) {
  for (const dysa::ParamDecl& d : dysa::ParamTable()) {
    const double x = d.get(a), y = d.get(b);
    if (std::memcmp(&x, &y, sizeof x) != 0) return false;
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const size_t eq = text.find('=');
  const bool has_name = eq != std::string_view::npos && eq > 0;

  std::optional<std::pair<std::string, double>> parsed;
  try {
    parsed = dysa::ParseAssignment(text);
  } catch (const dysa::ConfigError& e) {
    CheckError(e, "ParseAssignment");
    if (has_name && e.field() != dysa::SafeText(text.substr(0, eq))) {
      Finding(kHarness, "ParseAssignment's error names '" + e.field() + "', not the name");
    }
    if (!has_name && !e.field().empty()) {
      Finding(kHarness, "ParseAssignment's error without NAME= names '" + e.field() + "'");
    }
  } catch (...) {
    Unexpected("ParseAssignment");
  }
  if (parsed) {
    if (!has_name || parsed->first != text.substr(0, eq)) {
      Finding(kHarness, "ParseAssignment returned the name '" + parsed->first + "'");
    }
    if (!std::isfinite(parsed->second)) Finding(kHarness, "ParseAssignment returned non-finite");
    // "0e5" is 0, but "1e-400" must be refused, not read as 0: a zero has no digit 1-9 before
    // its exponent.
    const std::string_view value = text.substr(eq + 1);
    const std::string_view mantissa = value.substr(0, value.find_first_of("eE"));
    if (parsed->second == 0 && mantissa.find_first_of("123456789") != std::string_view::npos) {
      Finding(kHarness, "ParseAssignment read a nonzero number as 0");
    }
  }

  // SetParam with the parsed value, and SetParamFromString on the text: the same outcome.
  const dysa::Params defaults;
  dysa::Params by_value;
  bool value_set = false;
  if (parsed) {
    try {
      dysa::SetParam(by_value, parsed->first, parsed->second);
      value_set = true;
      if (dysa::GetParam(by_value, parsed->first) != parsed->second) {
        Finding(kHarness, "GetParam does not read back what SetParam stored");
      }
    } catch (const dysa::ConfigError& e) {
      CheckError(e, "SetParam");
      if (e.field().empty()) Finding(kHarness, "SetParam's error names no field");
      if (!SameParams(by_value, defaults)) Finding(kHarness, "SetParam threw but changed params");
    } catch (...) {
      Unexpected("SetParam");
    }
  }
  dysa::Params by_text;
  bool text_set = false;
  try {
    dysa::SetParamFromString(by_text, text);
    text_set = true;
  } catch (const dysa::ConfigError& e) {
    CheckError(e, "SetParamFromString");
    if (e.field().empty()) Finding(kHarness, "SetParamFromString's error names no field");
    if (!SameParams(by_text, defaults)) Finding(kHarness, "SetParamFromString threw but changed");
  } catch (...) {
    Unexpected("SetParamFromString");
  }
  if (text_set != value_set || !SameParams(by_text, by_value)) {
    Finding(kHarness, std::string("SetParamFromString ") + (text_set ? "set" : "refused") +
                          " what ParseAssignment + SetParam " + (value_set ? "set" : "refused"));
  }
  return 0;
}
