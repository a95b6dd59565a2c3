// Scenes beyond their JSON (scene_parse.cc reads that): the checks that need the parameters (a
// periodic domain's length, a block's particle counts), the built-in scenes, and loading a scene
// by name or path.
#include "dysa/core/scene.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

#include "dysa/core/neighbor_grid.h"
#include "dysa/core/solver.h"
#include "dysa/core/text.h"

namespace dysa {
namespace {

// A derived quantity (not a value the client gave), to 4 significant digits.
std::string Approx(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.4g", v);
  return text;
}

}  // namespace

void CheckPeriodicDomain(const Scene& scene, const Params& params) {
  const bool physical = IsPhysicalSolver(scene.solver);
  // The neighbour search's reach: the physical solvers' kernel support 2 h, the seed's h.
  const double support = physical ? 2 * params.smoothing_length_ratio * params.particle_spacing
                                  : params.smoothing_radius;
  const char* param = physical ? "particle_spacing" : "smoothing_radius";
  const char* axes = "xyz";
  for (int a = 0; a < 3; ++a) {
    if (!scene.periodic[a]) continue;
    const double length = scene.domain.max[a] - scene.domain.min[a];
    if (length < 3 * support * (1 - 1e-9)) {  // a hair under: 3 * 0.04 is 0.12000000000000001
      throw ConfigError(
          param,
          "the domain is periodic in " + std::string(1, axes[a]) + " with a length of " +
              ExactNumber(length) + " m, which must be at least 3 kernel supports; at most " +
              ExactNumber(length / (physical ? 6 * params.smoothing_length_ratio : 3)) + " m here");
    }
    auto check = [&](double lo, double hi, const std::string& path) {
      if (lo < scene.domain.min[a] + support || hi > scene.domain.max[a] - support) {
        throw ConfigError(path, "must lie at least one kernel support (" + ExactNumber(support) +
                                    " m) inside the periodic domain's faces along " +
                                    std::string(1, axes[a]) + "; obstacles do not wrap around");
      }
    };
    // A moving obstacle's path is linear between its keys, so its extremes are at keys.
    auto displacements = [](const ObstacleMotion& m) {
      std::vector<Vec3d> d;
      for (const ObstacleMotion::Key& k : m.keys) d.push_back(k.displacement);
      if (d.empty()) d.push_back(Vec3d::Zero());
      return d;
    };
    for (size_t i = 0; i < scene.spheres.size(); ++i) {
      const SphereObstacle& s = scene.spheres[i];
      for (const Vec3d& d : displacements(s.motion)) {
        check(s.center[a] + d[a] - s.radius, s.center[a] + d[a] + s.radius,
              "obstacles (sphere " + std::to_string(i) + ")");
      }
    }
    for (size_t i = 0; i < scene.boxes.size(); ++i) {
      const Aabb& b = scene.boxes[i].box;
      for (const Vec3d& d : displacements(scene.boxes[i].motion)) {
        check(b.min[a] + d[a], b.max[a] + d[a], "obstacles (box " + std::to_string(i) + ")");
      }
    }
  }
}

namespace {

// Refuses a block of `n` particles per axis whose particles would crowd one neighbour-grid cell
// beyond NeighborGrid::kMaxParticlesPerCell: per axis, as many of its lattice points as one cell
// edge spans (the grid's edge: the kernel's support, longer where kMaxCells caps a large
// domain). `spacing`: the block's spacing (a physical solver's particle_spacing, the block's
// own), else the thesis's edge-to-edge size / (n - 1).
void CheckParticlesPerCell(const Scene& scene, const Params& params, const FluidBlock& block,
                           const std::optional<double>& spacing, const Eigen::Vector3i& n,
                           const std::string& path) {
  const bool physical = IsPhysicalSolver(scene.solver);
  const double support = physical ? 2 * params.smoothing_length_ratio * params.particle_spacing
                                  : params.smoothing_radius;
  NeighborGrid grid;
  try {
    grid.Configure(scene.domain, Real(support), scene.periodic,
                   physical ? params.grid_cells_per_support : 1);
  } catch (const std::invalid_argument&) {
    return;  // a periodic axis too short for the grid: CheckPeriodicDomain names it
  }
  const Vec3d size = block.size.value_or(Vec3d::Constant(params.spawn_size));
  double per_cell = 1;
  double closest = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (n[a] < 2) continue;
    const double step = spacing ? *spacing : size[a] / (n[a] - 1);
    closest = std::min(closest, step);
    const double spanned = step > 0 ? std::floor(grid.cell_sizes()[a] / step) + 1 : double(n[a]);
    per_cell *= std::min(double(n[a]), spanned);
  }
  if (per_cell <= NeighborGrid::kMaxParticlesPerCell) return;
  const std::string cause = physical ? "params.particle_spacing" : "the block's spacing";
  throw ConfigError(
      path,
      "about " + (per_cell < 1e15 ? std::to_string(uint64_t(per_cell)) : Approx(per_cell)) +
          " particles (" + cause + " " + Approx(closest) +
          " m) would share one neighbour-grid cell of edge " +
          Approx(grid.cell_sizes().minCoeff()) + " m; at most " +
          std::to_string(NeighborGrid::kMaxParticlesPerCell) +
          " can, or every step costs O(n^2): space the particles further apart" +
          (physical ? std::string(" or shrink the domain")
                    : " (size, particles_per_axis, spacing) or lower params.smoothing_radius"));
}

}  // namespace

std::vector<Eigen::Vector3i> BlockParticleCounts(const Scene& scene, const Params& params) {
  std::vector<Eigen::Vector3i> counts;
  uint64_t total = 0;
  const bool physical = IsPhysicalSolver(scene.solver);
  for (size_t i = 0; i < scene.fluid_blocks.size(); ++i) {
    const FluidBlock& b = scene.fluid_blocks[i];
    const std::string path = "fluid_blocks[" + std::to_string(i) + "]";
    // A physical solver's particle mass is rest_density * particle_spacing^3, so its blocks are
    // filled at that spacing; a block's own count or spacing would contradict the mass.
    if (physical && (b.particles_per_axis || b.spacing)) {
      throw ConfigError(path + (b.spacing ? ".spacing" : ".particles_per_axis"),
                        "not allowed with the " + scene.solver +
                            " solver, which fills every block at params.particle_spacing");
    }
    Eigen::Vector3i n = Eigen::Vector3i::Constant(params.particle_quantity);
    if (b.particles_per_axis) n = *b.particles_per_axis;
    const std::optional<double> spacing =
        physical ? std::optional<double>(params.particle_spacing) : b.spacing;
    if (spacing) {
      const Vec3d size = b.size.value_or(Vec3d::Constant(params.spawn_size));
      for (int a = 0; a < 3; ++a) {
        const double cells = std::floor(size[a] / *spacing + 0.5);
        if (cells > double(kMaxParticles)) {
          throw ConfigError(physical ? std::string("params.particle_spacing") : path + ".spacing",
                            "gives more than " + std::to_string(kMaxParticles) +
                                " particles per axis in " + path);
        }
        n[a] = std::max(1, int(cells));
      }
    }
    // In double: the product of three per-axis counts can overflow any integer type.
    const double block = double(n.x()) * double(n.y()) * double(n.z());
    if (block > double(kMaxParticles) || double(total) + block > double(kMaxParticles)) {
      throw ConfigError(path, "the scene would have " + ExactNumber(double(total) + block) +
                                  " particles; the limit is " + std::to_string(kMaxParticles));
    }
    total += uint64_t(block);
    counts.push_back(n);
  }
  // Then how densely: a count within the limit may still crowd the neighbour grid.
  for (size_t i = 0; i < scene.fluid_blocks.size(); ++i) {
    const FluidBlock& b = scene.fluid_blocks[i];
    const std::optional<double> spacing =
        physical ? std::optional<double>(params.particle_spacing) : b.spacing;
    CheckParticlesPerCell(scene, params, b, spacing, counts[i],
                          "fluid_blocks[" + std::to_string(i) + "]");
  }
  return counts;
}

const std::vector<BuiltinSceneText>& BuiltinSceneTexts();

std::vector<std::string> BuiltinSceneNames() {
  std::vector<std::string> names;
  for (const BuiltinSceneText& s : BuiltinSceneTexts()) names.emplace_back(s.name);
  return names;
}

namespace {

// The text of the scene file at `path`. Throws ConfigError("scene", ...) saying why there is
// none: no such file (nor a built-in scene of that name), a directory, unreadable, too large.
std::string ReadSceneFile(const std::string& path) {
  namespace fs = std::filesystem;
  // Appended, not "'" + ... + "'": GCC 12 warns of a false overlap (-Wrestrict) on that once
  // inlined here.
  std::string shown = "'";
  shown += SafeText(path, 1024);
  shown += "'";
  std::error_code error;
  const fs::file_type type = fs::status(path, error).type();
  if (type == fs::file_type::not_found) {
    std::string names;
    for (const std::string& n : BuiltinSceneNames()) names += (names.empty() ? "" : ", ") + n;
    throw ConfigError(
        "scene", shown + ": no such file, and no built-in scene (" + names + ") has that name");
  }
  if (error) throw ConfigError("scene", "cannot read " + shown + ": " + error.message());
  if (type == fs::file_type::directory) {
    throw ConfigError("scene", shown + " is a directory, not a scene file");
  }
  std::ifstream file(path, std::ios::binary);
  if (!file) throw ConfigError("scene", "cannot read " + shown + ": " + std::strerror(errno));
  // Read in pieces up to the bound: a pipe or device has no size to check first.
  std::string text;
  char piece[1 << 16];
  while (file.read(piece, sizeof(piece)) || file.gcount() > 0) {
    text.append(piece, size_t(file.gcount()));
    if (text.size() > kMaxSceneFileBytes) {
      throw ConfigError("scene", shown + " is larger than " +
                                     std::to_string(kMaxSceneFileBytes >> 20) +
                                     " MiB, the most a scene file may be");
    }
  }
  if (file.bad()) throw ConfigError("scene", "cannot read " + shown + ": " + std::strerror(errno));
  return text;
}

}  // namespace

Scene LoadScene(std::string_view name_or_path) {
  for (const BuiltinSceneText& s : BuiltinSceneTexts()) {
    if (name_or_path == s.name) {
      Scene scene = ParseScene(s.json);
      if (scene.name.empty()) scene.name = s.name;
      return scene;
    }
  }
  const std::string path(name_or_path);
  const std::string text = ReadSceneFile(path);
  try {
    Scene scene = ParseScene(text);
    if (scene.name.empty()) {
      // Named after the file: made a name ParseScene would accept.
      const std::string base = std::filesystem::path(path).filename().string();
      scene.name = SafeText(base.substr(0, base.rfind(".json")), kMaxSceneNameBytes);
    }
    return scene;
  } catch (const ConfigError& e) {
    throw ConfigError(e.field(), e.message() + " (in " + SafeText(path, 1024) + ")");
  }
}

}  // namespace dysa
