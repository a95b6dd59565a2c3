#include "dysa/core/text.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace dysa {
namespace {

// The length of the well-formed UTF-8 sequence `text` starts with (1 to 4), its code point in
// `code`; 0 when the first byte starts none (a stray continuation byte, a truncated sequence, an
// overlong form, a surrogate or a code point above U+10FFFF).
size_t Utf8Sequence(std::string_view text, char32_t& code) {
  const auto byte = [&](size_t i) { return static_cast<unsigned char>(text[i]); };
  const unsigned char lead = byte(0);
  if (lead < 0x80) {
    code = lead;
    return 1;
  }
  size_t length = 0;
  char32_t smallest = 0;  // the smallest code point of this length: shorter forms are overlong
  if ((lead & 0xE0) == 0xC0) {
    length = 2, code = lead & 0x1F, smallest = 0x80;
  } else if ((lead & 0xF0) == 0xE0) {
    length = 3, code = lead & 0x0F, smallest = 0x800;
  } else if ((lead & 0xF8) == 0xF0) {
    length = 4, code = lead & 0x07, smallest = 0x10000;
  } else {
    return 0;
  }
  if (text.size() < length) return 0;
  for (size_t i = 1; i < length; ++i) {
    if ((byte(i) & 0xC0) != 0x80) return 0;
    code = (code << 6) | (byte(i) & 0x3F);
  }
  if (code < smallest || code > 0x10FFFF || (code >= 0xD800 && code <= 0xDFFF)) return 0;
  return length;
}

// C0 controls, DEL and C1 controls.
bool IsControl(char32_t code) {
  return code < 0x20 || code == 0x7F || (code >= 0x80 && code <= 0x9F);
}

// The first character of `text` as SafeText writes it; `consumed` is its length in `text`.
std::string SafeCharacter(std::string_view text, size_t& consumed) {
  char escaped[16];
  char32_t code = 0;
  consumed = Utf8Sequence(text, code);
  if (consumed == 0) {
    consumed = 1;
    std::snprintf(escaped, sizeof(escaped), "\\x%02x", static_cast<unsigned char>(text[0]));
    return escaped;
  }
  if (!IsControl(code)) return std::string(text.substr(0, consumed));
  if (code < 0x80) {
    if (code == '\n') return "\\n";
    if (code == '\r') return "\\r";
    if (code == '\t') return "\\t";
    std::snprintf(escaped, sizeof(escaped), "\\x%02x", unsigned(code));
    return escaped;
  }
  std::snprintf(escaped, sizeof(escaped), "\\u%04x", unsigned(code));
  return escaped;
}

// Appends the safe form of `text` to `out` while it fits in `budget` bytes; returns how many
// bytes of `text` it took.
size_t AppendWhileItFits(std::string_view text, size_t budget, std::string& out) {
  size_t taken = 0;
  while (taken < text.size()) {
    size_t consumed = 0;
    const std::string piece = SafeCharacter(text.substr(taken), consumed);
    if (out.size() + piece.size() > budget) break;
    out += piece;
    taken += consumed;
  }
  return taken;
}

}  // namespace

std::string SafeText(std::string_view text, size_t max_bytes) {
  // "... (18446744073709551615 bytes)" is 32 bytes; 40 leaves room for a few characters.
  max_bytes = std::max<size_t>(max_bytes, 40);
  std::string out;
  if (AppendWhileItFits(text, max_bytes, out) == text.size()) return out;
  const std::string ending = "... (" + std::to_string(text.size()) + " bytes)";
  out.clear();
  AppendWhileItFits(text, max_bytes - ending.size(), out);
  return out + ending;
}

bool HasUnsafeCharacters(std::string_view text) {
  for (size_t i = 0; i < text.size();) {
    char32_t code = 0;
    const size_t length = Utf8Sequence(text.substr(i), code);
    if (length == 0 || IsControl(code)) return true;
    i += length;
  }
  return false;
}

std::string ExactNumber(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  // %.17g always reads back exactly (a double has at most 17 significant decimal digits).
  char text[32];
  for (int digits = 6; digits <= 17; ++digits) {
    std::snprintf(text, sizeof(text), "%.*g", digits, value);
    if (std::strtod(text, nullptr) == value) break;
  }
  return text;
}

}  // namespace dysa
