// The JSON text of a scene read into a document, every failure a ConfigError naming where.
#pragma once

#include <nlohmann/json.hpp>
#include <string_view>

namespace dysa {

// How deep a scene's objects and arrays may nest: a scene needs 4 levels
// (probes[0].region.min[0]); deeper text is refused before it costs memory.
inline constexpr size_t kMaxSceneJsonDepth = 32;

// Parses `text`. Throws ConfigError, never a nlohmann exception:
// - malformed JSON: no field, "malformed JSON: ..." with the parser's line and column;
// - a number a double cannot hold, named by its path ("params.viscosity: 1e999 is out of the
//   range of a double", "... 1e-400 is too close to 0 for a double");
// - nesting deeper than kMaxSceneJsonDepth, named by its path.
// Client text in the messages (keys, the last token read) is quoted through SafeText.
nlohmann::json ParseSceneJson(std::string_view text);

}  // namespace dysa
