// libFuzzer target for dysa::ParseScene (server/core/src/scene.cc, scene_json.cc): the input is
// the scene's JSON text, as LoadScene's json_text or a scene file brings it.
//
// ParseScene promises a Scene or a ConfigError naming the field, and nothing else. Checked:
//   - no other exception, crash, sanitizer report or hang;
//   - a ConfigError's what() and field() are bounded (fuzz_checks.h) and escaped;
//   - a parsed scene keeps what scene.h bounds: name and probe names at most kMaxSceneNameBytes
//     without control characters, description at most kMaxSceneDescriptionBytes without control
//     characters but newlines and tabs, at most kMaxObstacles obstacles; BlockParticleCounts and
//     CheckPeriodicDomain with its own parameters return or throw ConfigError (checked the same
//     way), and the counts total at most kMaxParticles.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <string>
#include <string_view>
#include <typeinfo>

#include "dysa/core/scene.h"
#include "dysa/core/text.h"
#include "dysa/core/types.h"
#include "fuzz_checks.h"

namespace {

constexpr std::string_view kHarness = "scene_parser_fuzzer";

using dysa::fuzz::CheckSafeText;
using dysa::fuzz::Finding;

void CheckError(const dysa::ConfigError& e, std::string_view stage) {
  CheckSafeText(kHarness, std::string(stage) + " error", e.what());
  CheckSafeText(kHarness, std::string(stage) + " error's field", e.field());
}

// Text a scene keeps: `allowed` control characters aside, nothing SafeText would escape.
void CheckKeptText(std::string_view what, const std::string& text, size_t max_bytes,
                   std::string_view allowed) {
  if (text.size() > max_bytes) {
    Finding(kHarness, std::string(what) + " is " + std::to_string(text.size()) + " bytes");
  }
  std::string rest = text;
  for (char& c : rest) {
    if (allowed.find(c) != std::string_view::npos) c = ' ';
  }
  if (dysa::HasUnsafeCharacters(rest)) {
    Finding(kHarness, std::string(what) + " keeps control characters: " + text);
  }
}

void CheckScene(const dysa::Scene& scene) {
  CheckKeptText("name", scene.name, dysa::kMaxSceneNameBytes, "");
  CheckKeptText("description", scene.description, dysa::kMaxSceneDescriptionBytes, "\n\t");
  for (const dysa::ProbeSpec& probe : scene.probes) {
    CheckKeptText("probe name", probe.name, dysa::kMaxSceneNameBytes, "");
  }
  if (scene.spheres.size() + scene.boxes.size() > dysa::kMaxObstacles) {
    Finding(kHarness, std::to_string(scene.spheres.size() + scene.boxes.size()) + " obstacles");
  }
  try {
    uint64_t total = 0;
    for (const auto& n : dysa::BlockParticleCounts(scene, scene.params)) {
      if (n.minCoeff() < 1) Finding(kHarness, "a block spawns no particles along an axis");
      total += uint64_t(n.x()) * uint64_t(n.y()) * uint64_t(n.z());
    }
    if (total > dysa::kMaxParticles) {
      Finding(kHarness, "BlockParticleCounts accepted " + std::to_string(total) + " particles");
    }
    dysa::CheckPeriodicDomain(scene, scene.params);
  } catch (const dysa::ConfigError& e) {
    CheckError(e, "BlockParticleCounts");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const dysa::Scene scene = dysa::ParseScene(text);
    CheckScene(scene);
  } catch (const dysa::ConfigError& e) {
    CheckError(e, "ParseScene");
  } catch (const std::exception& e) {
    Finding(kHarness, std::string("ParseScene threw ") + typeid(e).name() + ": " + e.what());
  } catch (...) {
    Finding(kHarness, "ParseScene threw something that is not a std::exception");
  }
  return 0;
}
