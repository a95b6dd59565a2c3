// What every harness of fuzz/ checks of the errors it sees: a finding aborts (libFuzzer keeps the
// input), and an error message is bounded and escaped whatever the input was.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "dysa/core/text.h"

namespace dysa::fuzz {

// The longest message a parser error may have. Client text is quoted at most kMaxQuotedBytes
// at a time (SafeText), and a message quotes a bounded number of such pieces plus fixed text
// (field paths, ranges, lists of known names); the gRPC adapter cuts a status at
// kMaxStatusMessageBytes = 2048, so a longer message would reach no one whole.
inline constexpr size_t kMaxErrorBytes = 2048;

[[noreturn]] inline void Finding(std::string_view harness, const std::string& what) {
  std::fprintf(stderr, "%.*s: FINDING: %s\n", int(harness.size()), harness.data(),
               SafeText(what, 4096).c_str());
  std::fflush(stderr);
  std::abort();
}

// `text` (an error message, or a field name in one) is at most `max_bytes` long and has no raw
// control character or malformed UTF-8 (everything client-given in it went through SafeText).
inline void CheckSafeText(std::string_view harness, std::string_view what, std::string_view text,
                          size_t max_bytes = kMaxErrorBytes) {
  if (text.size() > max_bytes) {
    Finding(harness, std::string(what) + " is " + std::to_string(text.size()) +
                         " bytes long (at most " + std::to_string(max_bytes) +
                         " expected): " + std::string(text.substr(0, 300)));
  }
  if (HasUnsafeCharacters(text)) {
    Finding(harness, std::string(what) +
                         " has raw control characters or malformed UTF-8: " + std::string(text));
  }
}

}  // namespace dysa::fuzz
