// The gRPC client of the dysa.v1.Simulation service. The only code of the command line that
// sees generated protobuf types: it converts them to the plain structs below, so the verbs
// (remote_commands.h) and their tests build without the generated headers.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "dysa/codec/frame_codec.h"

namespace dysa::remote {

struct ConnectOptions {
  std::string address = "127.0.0.1:50051";
  std::string token;        // sent as "authorization: Bearer TOKEN" when not empty
  std::string tls_ca_file;  // PEM roots to trust; empty: an insecure (plaintext) channel
  // The name the server's certificate must carry, when it differs from the address's host
  // (e.g. a certificate for "localhost" reached as 127.0.0.1).
  std::string tls_server_name;
  // Deadlines: queries answer at once; controls wait until the simulation thread has applied
  // them, which for Step/StepBack/LoadScene includes simulating or re-spawning.
  std::chrono::milliseconds query_deadline{30'000};
  std::chrono::milliseconds control_deadline{300'000};
};

// A call that ended with a status other than OK. what() is "CODE_NAME: message".
class RpcError : public std::runtime_error {
 public:
  RpcError(int code, std::string code_name, std::string message);
  int code() const { return code_; }  // grpc::StatusCode
  const std::string& code_name() const { return code_name_; }
  const std::string& message() const { return message_; }

 private:
  int code_;
  std::string code_name_;
  std::string message_;
};

// The StatusCode names of gRPC ("INVALID_ARGUMENT"), for codes 0..16.
std::string StatusCodeName(int code);

struct PassTiming {
  std::string name;
  double last_ms = 0;
  double mean_ms = 0;
  uint64_t calls = 0;
};

// dysa.v1.Status.
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
  uint64_t device_memory_bytes = 0;  // bytes of GPU memory the simulation holds; 0 on the CPU
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

struct SphereObstacle {
  std::array<double, 3> center{};  // m
  double radius = 0;               // m
};

struct BoxObstacle {
  std::array<double, 3> min{};  // m
  std::array<double, 3> max{};  // m
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
};

// dysa.v1.FrameMessage.
struct FrameMessage {
  std::vector<codec::Chunk> chunks;
  uint64_t frame = 0;
  bool last_of_frame = false;
  uint64_t frame_bytes = 0;
  int64_t produced_unix_us = 0;
  uint32_t frames_skipped = 0;
};

// An open StreamFrames call.
class FrameStream {
 public:
  struct Impl;
  explicit FrameStream(std::unique_ptr<Impl> impl);
  ~FrameStream();  // cancels the call if it is still open
  FrameStream(const FrameStream&) = delete;
  FrameStream& operator=(const FrameStream&) = delete;

  // The next message; false once the stream has ended (then call Finish()).
  bool Next(FrameMessage& message);
  // Ends the call from any thread; a blocked Next() returns false soon after.
  void Cancel();
  // The call's final status: returns normally for OK and for a cancellation by Cancel(),
  // throws RpcError otherwise.
  void Finish();

 private:
  std::unique_ptr<Impl> impl_;
};

// One channel to one server. Every method throws RpcError when the call fails; UNAVAILABLE
// errors name the address.
class Client {
 public:
  // Throws std::runtime_error when the TLS CA file cannot be read.
  explicit Client(const ConnectOptions& options);
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  const std::string& address() const;

  ServerStatus GetStatus();
  ControlResult Pause();
  ControlResult Resume();
  ControlResult Step(uint32_t count);
  ControlResult StepBack(uint32_t count);
  ControlResult Reset();
  std::vector<ParamInfo> GetParams();
  // Applies `values` (name, value) with an update mask naming exactly those parameters.
  UpdateResult UpdateParams(const std::vector<std::pair<std::string, double>>& values);
  // `solver`: a registered solver name to run the scene with instead of its own; "": its own.
  ControlResult LoadSceneByName(const std::string& name, const std::string& solver = "");
  ControlResult LoadSceneText(const std::string& json_text, const std::string& solver = "");
  SceneList ListScenes();
  SceneDescription GetScene();
  std::unique_ptr<FrameStream> StreamFrames(const StreamOptions& options);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dysa::remote
