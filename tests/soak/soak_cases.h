// The fault and soak suite (issue 21): loads that a hostile or careless world puts on a real
// dysa-server process over loopback gRPC, each a function of its size, each checking that the
// server keeps answering, loses no accepted control and holds its memory within a stated bound.
// ctest -L soak runs the short sizes (tests/soak/soak_test.cc); bench/soak_bench the long ones
// (the issue's: 10,000 RPCs, 64 subscribers, 10 stalled readers for 60 s, 100 cycles).
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace dysa::soak {

// Where the programs are and where a case may write (its server's log, scene files).
struct SoakEnv {
  std::string server_binary;  // dysa-server
  std::string cli_binary;     // dysa: the client that ClientKilledMidStream kills
  std::filesystem::path work_dir;
};

struct Figure {
  std::string name;
  double value = 0;
  std::string unit;
};

// What a case measured, and every promise it saw broken (each with the figures that broke it).
struct SoakResult {
  std::string case_name;
  std::vector<Figure> figures;
  std::vector<std::string> failures;
  bool ok() const { return failures.empty(); }
  void Add(const std::string& name, double value, const std::string& unit = "") {
    figures.push_back({name, value, unit});
  }
  void Fail(const std::string& why) { failures.push_back(why); }
  // "name=value unit, ..." for a report.
  std::string Summary() const;
};

constexpr size_t kMiB = size_t{1} << 20;

// (1) `rpcs` mixed RPCs (GetStatus, GetParams, UpdateParams, Pause, Resume, Step, ListScenes,
// GetScene, LoadScene, StepBack) from `threads` threads against a running server: none fails,
// every accepted control's reply shows its effect (a paused reply after Pause, the value set
// after UpdateParams, the scene loaded after LoadScene...), and the resident memory grows by at
// most `max_growth` between the end of a warm-up round and the end.
struct RpcSoakSize {
  int rpcs = 2000;
  int threads = 4;
  size_t max_growth = 8 * kMiB;
};
SoakResult RpcSoak(const SoakEnv& env, const RpcSoakSize& size);

// (2) `cycles` times: a new connection subscribes (each cycle another stream configuration,
// every field), takes a whole frame and goes away; then `cap` streams at once (the server's
// --max-subscribers) and the one beyond refused with RESOURCE_EXHAUSTED naming the limit. After
// all: no subscriber left, and the resident memory within `max_growth` of where it was after the
// first cycle (a configuration's buffers are about 5 MB: a leak of each would show). The bound
// grows with the cores: `cap` streams encoding at once leave each encoding thread its scratch
// buffers and malloc arena (17.2 MiB on 16 cores against 10 to 12 on 2), which no later cycle adds
// to.
size_t ChurnGrowthBound();  // 16 MiB, and 2 MiB more per hardware thread beyond 2
struct ChurnSize {
  int cycles = 20;
  int cap = 8;
  size_t max_growth = ChurnGrowthBound();
};
SoakResult SubscriberChurn(const SoakEnv& env, const ChurnSize& size);

// (3) `readers` subscribers that stop reading for `seconds` while the simulation runs at
// --frame-rate `frame_rate`: frames per second meanwhile at least (1 - `max_slowdown`) of the
// rate measured without subscribers, GetStatus answered all along, and each reader (once it reads
// again) told that it skipped frames: proof that it did stall the server's writes.
struct StalledSize {
  int readers = 4;
  double seconds = 4;
  double frame_rate = 30;
  double max_slowdown = 0.25;
};
SoakResult StalledReaders(const SoakEnv& env, const StalledSize& size);

// (4) The hostile scenes of issue 21, each sent `rounds` times to a running server: a block
// crowding one neighbour-grid cell, a number a double cannot hold, a particle count past the
// limit, a 4 MB name, nesting 40 deep. Each refused with INVALID_ARGUMENT naming the field, in a
// bounded message; the old scene runs on unchanged (name, particles, scene_version, frames).
struct HostileSize {
  int rounds = 1;
};
SoakResult HostileScenes(const SoakEnv& env, const HostileSize& size);

// (5) SIGTERM while `streams` streams (half of them stalled) and `rpc_threads` threads of RPCs
// (a long Step among them) are in flight, after `load_seconds` of that load: the server exits 0
// within `max_seconds` of the signal.
struct SigtermSize {
  int streams = 4;
  int rpc_threads = 4;
  double load_seconds = 1;
  double max_seconds = 2;
};
SoakResult SigtermUnderLoad(const SoakEnv& env, const SigtermSize& size);

// (6) `cycles` times: a `dysa watch` process subscribes and is killed (SIGKILL) mid-stream, every
// other one first stopped (SIGSTOP) so that the server's write to it is stuck. The server answers
// GetStatus all along, its subscriber count goes back to 0 within `release_seconds` each time, and
// its resident memory ends within `max_growth` of where it was after the first two cycles.
struct KilledClientSize {
  int cycles = 6;
  double release_seconds = 30;
  size_t max_growth = 8 * kMiB;
};
SoakResult ClientKilledMidStream(const SoakEnv& env, const KilledClientSize& size);

}  // namespace dysa::soak
