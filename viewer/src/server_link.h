// The viewer's control connection: a worker thread that sends the user's commands (pause,
// step, parameter changes, ...) one at a time, polls the server's status four times a second
// and refetches the parameters and scene when they change or the server comes back. The UI
// reads a copy of what it knows (View()) and never waits for an RPC.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "dysa/client/client.h"

namespace dysa::viewer {

// A message for the user: an error the server returned or a notice ("reset").
struct UserMessage {
  std::string text;
  bool error = true;
  std::chrono::steady_clock::time_point when;
};

// Everything the panel shows about the server, as of the latest poll.
struct ServerView {
  bool connected = false;
  std::string connection_error;  // why the latest poll failed, when not connected
  remote::ServerStatus status;
  std::vector<remote::ParamInfo> params;  // declaration order; empty until fetched
  std::optional<remote::SceneDescription> scene;
  std::vector<remote::SceneInfo> scenes;  // built-in scenes
  uint64_t params_revision = 0;           // increments whenever `params` is refetched
  uint64_t scene_revision = 0;            // increments whenever `scene` is refetched
  int commands_in_flight = 0;
  std::deque<UserMessage> messages;  // newest last, at most kMaxMessages
};

class ServerLink {
 public:
  static constexpr size_t kMaxMessages = 6;

  // Throws std::runtime_error when the TLS CA file cannot be read.
  explicit ServerLink(const remote::ConnectOptions& options,
                      std::chrono::milliseconds poll_interval = std::chrono::milliseconds(250));
  ~ServerLink();  // Stop()
  ServerLink(const ServerLink&) = delete;
  ServerLink& operator=(const ServerLink&) = delete;

  void Start();
  void Stop();

  // Commands, queued and sent in order; failures become error messages in View().
  void Pause();
  void Resume();
  void TogglePause();  // from the latest known state
  void Step(uint32_t frames);
  void StepBack(uint32_t frames);
  void Reset();
  void SetParam(const std::string& name, double value);
  void LoadScene(const std::string& name, const std::string& solver = "");

  ServerView View() const;
  void DismissMessages();

  // Blocks until every queued command has been sent and answered (tests, --screenshot).
  void WaitIdle();

 private:
  using Command = std::function<void(remote::Client&)>;
  void Enqueue(std::string what, Command command);
  void Loop();
  void Poll();
  void Note(std::string text, bool error);
  void ApplyStatus(const remote::ServerStatus& status);

  remote::Client client_;
  const std::chrono::milliseconds poll_interval_;

  mutable std::mutex mu_;
  std::condition_variable wake_;
  std::condition_variable idle_;
  std::deque<std::pair<std::string, Command>> queue_;
  bool busy_ = false;
  bool stop_ = false;
  ServerView view_;
  bool refetch_ = true;  // parameters, scene and scene list are stale

  std::thread thread_;
};

}  // namespace dysa::viewer
