// Text for messages and logs: client strings made safe to keep, log or send back, and numbers
// printed as exactly the value they stand for.
//
// A scene file, an RPC argument or a command-line value may be any bytes of any length. Every
// such string that an error message quotes or a log line contains goes through SafeText() first:
// control characters cannot forge a log line or drive a terminal, and a 4 MB field name cannot
// make an error larger than the message limits of gRPC.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace dysa {

// How much of a client string an error message quotes: enough to recognise it.
inline constexpr size_t kMaxQuotedBytes = 100;

// `text` with every control character escaped and its length bounded:
// - C0 controls and DEL as \n, \r, \t or \xNN (NUL is \x00), C1 controls (U+0080 to U+009F) as
//   \uNNNN, and each byte that is not part of well-formed UTF-8 as \xNN; everything else is kept,
//   so the result is well-formed UTF-8 without control characters;
// - when the escaped text exceeds `max_bytes`, it is cut at a character boundary and ends in
//   "... (N bytes)", N being the length of `text`, so that the whole result is at most
//   `max_bytes` long (at least 40, which the ending needs).
// Backslashes are kept as they are, so SafeText is idempotent: text made safe once passes
// unchanged through a later SafeText with the same or a larger bound (an error message quoting
// safe text is itself bounded again where it leaves the server).
std::string SafeText(std::string_view text, size_t max_bytes = kMaxQuotedBytes);

// True when SafeText would escape something in `text` (a control character, or bytes that are
// not well-formed UTF-8); its length does not matter.
bool HasUnsafeCharacters(std::string_view text);

// `value` with as few significant digits as read back exactly, but at least the 6 of printf's
// %g ("0.1", "1e-05", "100000", "2.0000000001", "inf", "nan"), so an error shows the value it
// refused, not a rounded one that may look allowed.
std::string ExactNumber(double value);

}  // namespace dysa
