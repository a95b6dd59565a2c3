// Small scene files for the soak cases: the seed model, one block of n^3 particles.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>

namespace dysa::soak {

inline std::string SceneText(const std::string& name, int particles_per_axis) {
  return R"({"name": ")" + name + R"(", "params": {"particle_quantity": )" +
         std::to_string(particles_per_axis) + "}}";
}

// Writes `dir`/NAME.json; returns its path.
inline std::string WriteScene(const std::filesystem::path& dir, const std::string& name,
                              int particles_per_axis) {
  const std::filesystem::path path = dir / (name + ".json");
  std::ofstream(path) << SceneText(name, particles_per_axis);
  return path.string();
}

}  // namespace dysa::soak
