// The plain C++ view of the dysa.v1 messages a client receives and sends: status, parameters,
// scenes, stream options and frame messages. No generated protobuf types: code that includes
// this (the CLI's verbs, the viewer's panel and renderers) builds without the generated headers.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "dysa/codec/frame_codec.h"

namespace dysa::remote {

struct PassTiming {
  std::string name;
  double last_ms = 0;
  double mean_ms = 0;
  uint64_t calls = 0;
};

// dysa.v1.Status.
// dysa.v1.StreamStatus: one open frame stream as the server measures it.
struct StreamStatus {
  double detail = 1;                 // fraction of the particles sent
  uint32_t particles = 0;            // in its latest delivered frame
  double bytes_per_second = 0;       // delivered
  double frames_per_second = 0;      // delivered
  double age_s = 0;                  // s, age of its latest delivered frame's data
  double link_bytes_per_second = 0;  // measured while sending; 0: not yet
  double fps_target = 0;             // its budget; 0: none
  uint64_t byte_budget = 0;          // bytes/s; 0: none
  uint32_t particle_budget = 0;      // particles/frame; 0: none
  uint64_t stream_id = 0;            // FrameMessage.stream_id of the call
  bool view = false;                 // it has a camera (SetStreamView)
};

struct ServerStatus {
  std::string state;  // "running", "paused" or "unspecified"
  uint64_t step = 0;
  uint64_t frame = 0;
  double time = 0;  // s
  uint32_t particles = 0;
  std::string solver;
  std::string scene;
  double frames_per_second = 0;
  double target_frame_rate = 0;
  std::vector<PassTiming> passes;
  uint32_t subscribers = 0;
  std::string alarm;
  std::string warning;  // the solver's latest accuracy warning; empty when none
  uint64_t history_frames = 0;
  uint64_t history_bytes = 0;
  uint64_t frames_encoded = 0;
  uint64_t state_hash = 0;      // while paused: equal hashes mean bit-identical states; 0 running
  uint64_t scene_version = 0;   // changes whenever GetScene() would answer differently
  uint32_t solver_threads = 0;  // OpenMP threads the solver steps with
  // "cpu", or e.g. "cuda:0 NVIDIA H200, 139.8 GiB, sm_90"; empty from a server that predates it.
  std::string device;
  uint64_t device_memory_bytes = 0;   // bytes of GPU memory the simulation holds; 0 on the CPU
  std::vector<StreamStatus> streams;  // each open frame stream
};

struct ControlResult {
  ServerStatus status;
  bool reset = false;
  uint32_t frames_moved = 0;
};

struct ParamInfo {
  std::string name;
  double value = 0;
  std::string unit;
  double min = 0;
  double max = 0;
  double default_value = 0;
  bool integer = false;
  bool needs_reset = false;
  std::string description;
  // The solvers that read it (SceneDescription::solvers' names); the others ignore it. Empty
  // from a server older than this field.
  std::vector<std::string> solvers;

  // Whether `solver` reads it; true when either is unknown (empty).
  bool ReadBy(const std::string& solver) const {
    return solver.empty() || solvers.empty() ||
           std::find(solvers.begin(), solvers.end(), solver) != solvers.end();
  }
};

struct UpdateResult {
  bool reset = false;
  std::vector<ParamInfo> params;
  ServerStatus status;
};

struct SceneInfo {
  std::string name;
  std::string description;
  uint32_t particles = 0;
  std::string solver;
};

struct SceneList {
  std::vector<SceneInfo> scenes;
  std::string current;
};

// dysa.v1.ObstacleMotion: a prescribed translation, linear in time between keys; before the
// first key the displacement is the first key's, after the last key the last's.
struct ObstacleMotion {
  struct Key {
    double time = 0;                       // s, simulated time
    std::array<double, 3> displacement{};  // m, from the obstacle's given position
  };
  std::vector<Key> keys;  // times strictly increasing; empty: static

  bool moving() const { return !keys.empty(); }
  // m: where the obstacle is at simulated time t, relative to its given position (the core's
  // ObstacleMotion::DisplacementAt, so a client draws it where the solver has it).
  std::array<double, 3> DisplacementAt(double t) const;
};

struct SphereObstacle {
  std::array<double, 3> center{};  // m, with no displacement
  double radius = 0;               // m
  ObstacleMotion motion;
};

struct BoxObstacle {
  std::array<double, 3> min{};  // m, with no displacement
  std::array<double, 3> max{};  // m, with no displacement
  ObstacleMotion motion;
};

// dysa.v1.SceneDescription: the running scene's geometry and the registered solvers.
struct SceneDescription {
  std::string name;
  std::string description;
  std::string solver;                  // the running solver
  std::vector<std::string> solvers;    // every registered solver name
  std::array<double, 3> domain_min{};  // m
  std::array<double, 3> domain_max{};  // m
  std::vector<SphereObstacle> spheres;
  std::vector<BoxObstacle> boxes;
  double particle_radius = 0;  // m, half the smallest rest spacing of the spawned particles
  uint64_t scene_version = 0;  // as ServerStatus::scene_version
};

// dysa.v1.StreamFramesRequest; 0 keeps the server's default.
struct StreamOptions {
  uint32_t fields = codec::kPositions | codec::kSpeed;  // dysa::codec::Field bits
  double max_fps = 0;
  uint32_t stride = 0;
  uint32_t position_bits = 0;
  uint32_t speed_bits = 0;
  uint32_t velocity_bits = 0;
  uint32_t density_bits = 0;
  uint32_t keyframe_interval = 0;
  codec::VelocityEncoding velocity_encoding = codec::VelocityEncoding::kComponents;
  // Budgets (docs/server.md, "Budgets and detail"): the server then sends a subset of the
  // particles that holds the frame rate on this link. 0: none.
  double fps_target = 0;         // frames per second, (0, 1000]
  uint64_t byte_budget = 0;      // bytes per second, >= 1000; needs fps_target
  uint32_t particle_budget = 0;  // particles per frame
  // With a budget: report each frame received (AckFrames), so that the server measures what the
  // link delivers rather than what its transport took.
  bool acknowledge = true;
};

// dysa.v1.FrameMessage.
struct FrameMessage {
  std::vector<codec::Chunk> chunks;
  uint64_t frame = 0;
  bool last_of_frame = false;
  uint64_t frame_bytes = 0;
  int64_t produced_unix_us = 0;
  uint32_t frames_skipped = 0;
  uint64_t stream_id = 0;  // the call's id for SetStreamView (its first message only); 0: none
  bool refines = false;    // adds its particles to the frame before (progressive completion)
  bool partial = false;    // the frame shown still lacks particles; refinements follow if paused
};

// A camera for Client::SetStreamView, in the scene's metres (SetStreamViewRequest).
struct StreamCamera {
  std::array<double, 3> eye{};
  std::array<double, 3> target{};
  std::array<double, 3> up{0, 1, 0};
  double fov_y_deg = 45;  // [1, 179]
  double aspect = 1;      // width / height, [0.05, 20]
  bool operator==(const StreamCamera&) const = default;
};

}  // namespace dysa::remote
