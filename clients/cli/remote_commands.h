// The network verbs of `dysa` (status, pause, ..., watch, record): each calls the server through
// a remote::Client (dysa_client, clients/cpp) and prints to an ostream, human-readable or as one
// JSON object, so tests capture what the command line prints. Errors are thrown, main.cc prints
// them. One file per group of verbs: remote_status.cc, remote_control.cc (pause, resume, step,
// back, reset), remote_params.cc (params, set), remote_scenes.cc (load, scenes, scene),
// remote_watch.cc, remote_record.cc; remote_format.h and stream_watchdog.h are what they share.
#pragma once

#include <atomic>
#include <cstdint>
#include <iosfwd>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "dysa/client/client.h"

namespace dysa::remote {

// A mistake in the command line found before any call (exit status 2).
class UsageError : public std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The most frames `dysa step` and `dysa back` ask for: the server's limit on one Step or
// StepBack (kMaxStepCount, server/service/include/dysa/service/simulation_host.h).
inline constexpr uint32_t kMaxStepFrames = 10000;

void PrintStatus(Client& client, bool json, std::ostream& out);

enum class ControlVerb { kPause, kResume, kStep, kStepBack, kReset };
// `count` is the frames of kStep and kStepBack.
void RunControl(Client& client, ControlVerb verb, uint32_t count, bool json, std::ostream& out);

void PrintParams(Client& client, bool json, std::ostream& out);

// "NAME=VALUE" arguments as (name, value), in order. The value must be a finite number written
// in full ("1e-3", not "1e-3x"); a name may appear once. Names and ranges are the server's to
// check (it may be a newer version). Throws UsageError naming the parameter.
std::vector<std::pair<std::string, double>> ParseAssignments(
    const std::vector<std::string>& assignments);
// Parses everything first, then makes one UpdateParams call (all or nothing).
void SetParams(Client& client, const std::vector<std::string>& assignments, bool json,
               std::ostream& out);

// `scene` is an existing file (its text is sent) or a built-in scene name. `solver`: a
// registered solver to run it with instead of its own; "": the scene's. Throws
// std::runtime_error saying "no such file" for a missing path (a name with a '/' or ending in
// .json), "is a directory" for one, and "neither a file here nor a built-in scene" for a name
// the server does not know.
void LoadScene(Client& client, const std::string& scene, const std::string& solver, bool json,
               std::ostream& out);

// The running scene: solver (and the registered ones), domain, obstacles, particle radius.
void PrintScene(Client& client, bool json, std::ostream& out);

void PrintScenes(Client& client, bool json, std::ostream& out);

// Field names ("positions", "speed", "velocity", "density") as dysa::codec::Field bits;
// positions are always included. Throws UsageError for an unknown name.
uint32_t ParseFields(const std::vector<std::string>& names);

struct WatchOptions {
  StreamOptions stream;
  // Given to the stream once its id is known (SetStreamView): view-dependent detail.
  std::optional<StreamCamera> camera;
  double seconds = 0;  // stop after this long; 0: until *interrupted
  bool live = false;   // out is a terminal: one line rewritten in place (\r), else a line a second
  bool json = false;   // no status lines; one JSON summary at the end
  const std::atomic<bool>* interrupted = nullptr;  // set by a SIGINT handler; ends the watch
};

// Names the scene and the device it runs on (one GetStatus), then opens StreamFrames, decodes
// every frame and shows frame, simulated time, particles, frames/s received, bytes per frame and
// per particle, and the latency since the server produced it.
// An interruption or the end of `seconds` is a normal end.
void Watch(Client& client, const WatchOptions& options, std::ostream& out);

struct RecordOptions {
  StreamOptions stream;
  std::optional<StreamCamera> camera;  // as WatchOptions::camera
  uint64_t frames = 1;                 // complete decoded frames to write
  std::string out;     // npz: the file; vtk: OUT.pvd (or OUT if it ends in .pvd) and OUT/; missing
                       // directories on the way are made
  std::string format;  // "vtk" or "npz"; "" picks npz for a .npz file name, vtk otherwise
  bool json = false;
  bool progress = false;  // a live "k/N frames" line on `err`
  const std::atomic<bool>* interrupted = nullptr;
};

// Receives options.frames frames and writes them. vtk: one .vtp per frame (positions, the fields
// received, id: each particle's, k * stride or the detail subset's) and a .pvd; npz: positions
// (F,N,3) float32, speed/density (F,N) and velocity (F,N,3) when received, time float64 (F), step
// and frame uint64 (F), ids uint32 (N). When interrupted, writes the frames received so far and
// throws std::runtime_error saying so; the same when the particle count changes in an npz
// recording.
void Record(Client& client, const RecordOptions& options, std::ostream& out, std::ostream& err);

}  // namespace dysa::remote
