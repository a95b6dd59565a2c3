// What the simulation thread tells about itself (GetStatus, GetScene), as copies the RPC
// handlers read without waiting for a step.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "dysa/core/scene.h"
#include "dysa/service/detail_controller.h"

namespace dysa {
class Simulation;
}

namespace dysa::service {

struct PassStatus {
  std::string name;
  double last_ms = 0;
  double mean_ms = 0;
  uint64_t calls = 0;
};

struct HostStatus {
  bool running = false;
  uint64_t step = 0;
  uint64_t frame = 0;
  double time = 0;  // s
  uint32_t particles = 0;
  std::string solver;
  std::string scene;
  double frames_per_second = 0;  // simulated frames per wall second, over the last second
  double target_frame_rate = 0;
  // The solver's passes, then "keep_frame_start" once a frame was long enough for its start to
  // be kept (FrameStepper: a checkpoint, so that a pause can roll the frame back; per frame
  // kept), "record_history" (the step-back history's bookkeeping at each frame's end: a
  // checkpoint of the state every History::interval() frames, on the simulation thread), then,
  // once anyone has subscribed, "gather_frames" (copying the particles into a frame in id order,
  // on the simulation thread) and "publish_frames" (encoding it and starting the writes, on the
  // publishing thread), per frame.
  std::vector<PassStatus> passes;
  uint32_t solver_threads = 0;  // OpenMP threads the simulation thread steps with
  // Simulation::DeviceDescription(): "cpu" or e.g. "cuda:0 NVIDIA H200, 139.8 GiB, sm_90".
  std::string device;
  uint64_t device_memory_bytes = 0;  // bytes of GPU memory the simulation holds; 0 on the CPU
  uint32_t subscribers = 0;
  std::string alarm;    // empty when healthy
  std::string warning;  // the solver's latest accuracy warning (Simulation::warning())
  uint64_t history_frames = 0;
  uint64_t history_bytes = 0;
  uint64_t frames_encoded = 0;
  std::vector<StreamReport> streams;  // each open stream, in subscription order
  // StateHash while paused and no Step runs (0 otherwise: not worth a frame's time). Paused, the
  // state is always a frame (FrameStepper): this is the hash of the frame described above.
  uint64_t state_hash = 0;
  // Changes whenever CurrentScene() changes: a scene loaded, or a parameter change that
  // re-spawned the fluid. Starts at 1.
  uint64_t scene_version = 0;
};

// The running scene, as GetScene describes it.
struct HostScene {
  Scene scene;                 // as loaded, with the solver it runs
  double particle_radius = 0;  // m, SpawnParticleRadius with the current parameters
  uint64_t scene_version = 0;  // HostStatus::scene_version of this description
};

// The simulation's own part of a HostStatus: clock, particles, solver, passes, device, alarm,
// warning and, when `hash`, the state hash. On a GPU the hash copies every particle array back:
// ask for it only while paused.
void DescribeSimulation(const Simulation& sim, bool hash, HostStatus& status);

}  // namespace dysa::service
