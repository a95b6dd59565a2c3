// dysa_client: a C++ client of the dysa.v1.Simulation service. One channel to one server
// (address, bearer token, TLS), the unary calls (status, pause, resume, step, step back, reset,
// parameters, scenes) and the StreamFrames call. Only this library's sources see the generated
// protobuf types: they convert them to the plain structs of types.h, so the CLI's verbs, the
// viewer and their tests build without the generated headers.
#pragma once

#include <chrono>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "dysa/client/types.h"

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
  // Gives stream `stream_id` (FrameMessage::stream_id) this camera: view-dependent detail.
  void SetStreamView(uint64_t stream_id, const StreamCamera& camera);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dysa::remote
