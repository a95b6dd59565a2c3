// Scenes: what to simulate, read from JSON. scenes/README.md documents every field.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "dysa/core/params.h"
#include "dysa/core/types.h"

namespace dysa {

// The largest particle count a scene may ask for; a larger one is rejected before anything is
// allocated. A particle takes about 60 bytes of host memory and, on a GPU, 124 bytes of device
// memory (bench/gpu_bench), so this is about 30 GB of host and 62 GB of GPU memory; ids and
// indices stay 32-bit.
inline constexpr uint64_t kMaxParticles = 500'000'000;
// What a scene keeps of client text, and its obstacles, are bounded: every reply that describes
// the running scene (status, GetScene) then stays far below gRPC's 4 MiB message limit whatever
// a scene holds, and every log line naming it stays one short line (ParseScene refuses more,
// naming the field and the bound; names and descriptions without control characters, but for
// a description's newlines and tabs). A box obstacle is 60 bytes of a GetScene reply.
inline constexpr size_t kMaxSceneNameBytes = 256;  // name, and each probe's name
inline constexpr size_t kMaxSceneDescriptionBytes = 4096;
inline constexpr size_t kMaxObstacles = 10'000;
// LoadScene reads no more of a file (the server takes at most 4 MiB of scene text from a call).
inline constexpr size_t kMaxSceneFileBytes = size_t{64} << 20;
// The most a server simulates and streams by default (dysa-server --max-particles): the frame
// codec's decoders allocate for at most this many.
inline constexpr uint64_t kMaxStreamedParticles = 20'000'000;

// A cuboid of fluid. Unset fields take the spawn parameters (particle_quantity, spawn_size,
// spawn_jitter), as the thesis's single spawn cube did.
struct FluidBlock {
  std::optional<Vec3d> center;  // m; default: the centre of the domain
  std::optional<Vec3d> size;    // m; default: spawn_size on every axis
  // At most one of particles_per_axis and spacing is set; neither means particle_quantity per
  // axis. With a count n the particles span the block edge to edge (the thesis's spawner);
  // with a spacing d they sit at the centres of d-sized cells filling the block.
  std::optional<Eigen::Vector3i> particles_per_axis;
  std::optional<double> spacing;   // m
  std::optional<double> jitter;    // m
  uint64_t seed = 1;               // random seed of the jitter
  Vec3d velocity = Vec3d::Zero();  // m/s, initial velocity
};

// The most keyframes one obstacle's motion may have, and all obstacles' together: a scene's
// motions then stay a small part of a GetScene reply (a key is 32 bytes).
inline constexpr size_t kMaxMotionKeys = 1000;
inline constexpr size_t kMaxSceneMotionKeys = 10'000;

// A prescribed rigid translation of an obstacle (scene field "motion"): its displacement from
// the position the scene gives, linear in time between keyframes; before the first key it is
// the first key's, after the last key the last's. A constant velocity v over [t0, t1] is the two
// keys (t0, 0) and (t1, v (t1 - t0)). Key times strictly increase (ParseScene checks).
struct ObstacleMotion {
  struct Key {
    double time = 0;                     // s
    Vec3d displacement = Vec3d::Zero();  // m
  };
  std::vector<Key> keys;  // empty: static

  bool moving() const { return !keys.empty(); }
  Vec3d DisplacementAt(double t) const;
  // The slope of the segment holding t (the later one at a key's time); 0 outside the keys.
  Vec3d VelocityAt(double t) const;
};

struct SphereObstacle {
  Vec3d center = Vec3d::Zero();  // m
  double radius = 0.5;           // m
  ObstacleMotion motion;
};

struct BoxObstacle {
  Aabb box;  // m
  ObstacleMotion motion;
};

enum class ProbeKind {
  kFront,          // largest coordinate of any particle along `axis` (surge front), m
  kHeight,         // height of the connected water column at (x, z) of `point`, m
  kPressure,       // pressure interpolated at `point`, Pa
  kWallPressure,   // pressure a sensor at `point` on a wall or obstacle face reads, Pa
  kDensity,        // mean and max density of all particles, kg/m^3 (two columns)
  kKineticEnergy,  // sum of m |v|^2 / 2, J
  kCountInside,    // number of particles inside `region` (default: the domain)
  // The fluid's pressure force on a box obstacle, N (three columns, NAME_x, NAME_y, NAME_z):
  // the wall pressure integrated over its faces (probes.h, BoxForceOn).
  kBoxForce,
};

struct ProbeSpec {
  ProbeKind kind = ProbeKind::kKineticEnergy;
  std::string name;  // column name in probes.csv
  int axis = 0;      // kFront: 0, 1, 2 for x, y, z
  Vec3d point = Vec3d::Zero();
  double radius = 0;  // kHeight: horizontal search radius, m; 0 = the kernel support
  // kHeight: the largest vertical gap, m, between particles of one connected column (0 = the
  // kernel support); spray above a larger gap is not the column's.
  double gap = 0;
  // kWallPressure: the face's normal, pointing into the fluid (any length above 0; zero = all
  // particles around the point count, whichever side of the face they are on).
  Vec3d normal = Vec3d::Zero();
  std::optional<Aabb> region;
  // kBoxForce: the box (an index into Scene::boxes), and the side of the square patches its
  // faces are sampled on, m (0 = the kernel's support).
  int box = -1;
  double spacing = 0;
};

struct Scene {
  std::string name;
  std::string description;
  Aabb domain{Vec3d(-5, -3, -5), Vec3d(5, 3, 5)};
  // Axes along which the domain wraps around instead of having walls (domain.periodic).
  Periodicity periodic{};
  // Axes whose two walls hold the fluid at rest (domain.no_slip; physical solvers with a
  // kinematic viscosity): the fluid's velocity falls to 0 at the wall. The other walls, and
  // obstacles, are free-slip.
  std::array<bool, 3> no_slip{};
  std::vector<FluidBlock> fluid_blocks;
  std::vector<SphereObstacle> spheres;
  std::vector<BoxObstacle> boxes;
  std::string solver = "seed";
  Params params;
  double end_time = 5.0;                 // s, default length of an offline run
  std::optional<double> probe_interval;  // s; default: one output per frame
  std::vector<ProbeSpec> probes;
  // The JSON text ParseScene read this scene from (empty for a scene built in code): what the
  // server sends its other ranks to build the same scene (docs/distributed.md).
  std::string source_json;
};

// Parses a scene from JSON text. Every field is optional and has a default; malformed JSON, an
// unknown field, a wrong type or an out-of-range value (a number a double cannot hold included)
// throws ConfigError naming the field and the allowed range, quoting client text through
// SafeText; no other exception escapes.
Scene ParseScene(std::string_view json_text);

// A scene name (built-in) or a path to a JSON file. Throws ConfigError: field "scene" when there
// is no such built-in scene or file, or the path is a directory, unreadable or over
// kMaxSceneFileBytes; ParseScene's errors with " (in PATH)" added.
Scene LoadScene(std::string_view name_or_path);

struct BuiltinSceneText {
  const char* name;
  const char* json;
};
// The scenes/*.json files compiled into the binary (generated at build time).
const std::vector<BuiltinSceneText>& BuiltinSceneTexts();
std::vector<std::string> BuiltinSceneNames();

// The number of particles each block spawns with the given parameters, checked against
// kMaxParticles (throws ConfigError naming the block).
std::vector<Eigen::Vector3i> BlockParticleCounts(const Scene& scene, const Params& params);

// Checks what a periodic axis needs with these parameters: a length of at least 3 kernel
// supports (the neighbour grid's 3 cells; a shorter period would make a particle its own
// neighbour), and obstacles at least one support inside both of its faces (obstacles do not
// wrap). Throws ConfigError naming the field and the bound.
void CheckPeriodicDomain(const Scene& scene, const Params& params);

}  // namespace dysa
