#include "server_link.h"

#include <utility>

namespace dysa::viewer {

namespace {
using Clock = std::chrono::steady_clock;
}  // namespace

ServerLink::ServerLink(const remote::ConnectOptions& options,
                       std::chrono::milliseconds poll_interval)
    : client_([&] {
        // Short deadlines: a dead server shows as "disconnected" within a second or two
        // instead of holding the queue; a Step of many frames may still take its time.
        remote::ConnectOptions o = options;
        o.query_deadline = std::chrono::milliseconds(2000);
        o.control_deadline = std::chrono::milliseconds(60'000);
        return o;
      }()),
      poll_interval_(poll_interval) {}

ServerLink::~ServerLink() { Stop(); }

void ServerLink::Start() {
  std::lock_guard lock(mu_);
  if (thread_.joinable()) return;
  stop_ = false;
  thread_ = std::thread([this] { Loop(); });
}

void ServerLink::Stop() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  idle_.notify_all();
}

void ServerLink::Pause() {
  Enqueue("pause", [this](remote::Client& c) { ApplyStatus(c.Pause().status); });
}
void ServerLink::Resume() {
  Enqueue("resume", [this](remote::Client& c) { ApplyStatus(c.Resume().status); });
}
void ServerLink::TogglePause() {
  bool running;
  {
    std::lock_guard lock(mu_);
    running = view_.status.state == "running";
  }
  running ? Pause() : Resume();
}
void ServerLink::Step(uint32_t frames) {
  Enqueue("step", [this, frames](remote::Client& c) { ApplyStatus(c.Step(frames).status); });
}
void ServerLink::StepBack(uint32_t frames) {
  Enqueue("step back", [this, frames](remote::Client& c) {
    const remote::ControlResult r = c.StepBack(frames);
    ApplyStatus(r.status);
    if (r.frames_moved < frames) Note("no earlier frame kept: at the oldest one in history", false);
  });
}
void ServerLink::Reset() {
  Enqueue("reset", [this](remote::Client& c) { ApplyStatus(c.Reset().status); });
}

void ServerLink::SetParam(const std::string& name, double value) {
  Enqueue("set " + name, [this, name, value](remote::Client& c) {
    remote::UpdateResult r = c.UpdateParams({{name, value}});
    ApplyStatus(r.status);
    std::lock_guard lock(mu_);
    view_.params = std::move(r.params);
    ++view_.params_revision;
    if (r.reset) {
      refetch_ = true;  // the spawn may have changed the particle size
      view_.messages.push_back({"changing " + name + " reset the simulation", false, Clock::now()});
      while (view_.messages.size() > kMaxMessages) view_.messages.pop_front();
    }
  });
}

void ServerLink::LoadScene(const std::string& name, const std::string& solver) {
  Enqueue("load " + name, [this, name, solver](remote::Client& c) {
    ApplyStatus(c.LoadSceneByName(name, solver).status);
    std::lock_guard lock(mu_);
    refetch_ = true;
  });
}

ServerView ServerLink::View() const {
  std::lock_guard lock(mu_);
  ServerView copy = view_;
  copy.commands_in_flight = int(queue_.size()) + (busy_ ? 1 : 0);
  return copy;
}

void ServerLink::DismissMessages() {
  std::lock_guard lock(mu_);
  view_.messages.clear();
}

void ServerLink::WaitIdle() {
  std::unique_lock lock(mu_);
  idle_.wait(lock, [this] { return stop_ || (queue_.empty() && !busy_); });
}

void ServerLink::Enqueue(std::string what, Command command) {
  {
    std::lock_guard lock(mu_);
    queue_.emplace_back(std::move(what), std::move(command));
  }
  wake_.notify_all();
}

void ServerLink::Note(std::string text, bool error) {
  std::lock_guard lock(mu_);
  view_.messages.push_back({std::move(text), error, Clock::now()});
  while (view_.messages.size() > kMaxMessages) view_.messages.pop_front();
}

void ServerLink::ApplyStatus(const remote::ServerStatus& status) {
  std::lock_guard lock(mu_);
  const bool scene_changed = view_.status.scene_version != status.scene_version;
  view_.status = status;
  view_.connected = true;
  view_.connection_error.clear();
  if (scene_changed) refetch_ = true;
}

void ServerLink::Poll() {
  remote::ServerStatus status;
  try {
    status = client_.GetStatus();
  } catch (const std::exception& e) {
    std::lock_guard lock(mu_);
    view_.connected = false;
    view_.connection_error = e.what();
    refetch_ = true;  // the server may come back as a different process
    return;
  }
  ApplyStatus(status);

  bool refetch;
  {
    std::lock_guard lock(mu_);
    refetch = refetch_;
  }
  if (!refetch) return;
  try {
    std::vector<remote::ParamInfo> params = client_.GetParams();
    remote::SceneDescription scene = client_.GetScene();
    remote::SceneList scenes = client_.ListScenes();
    std::lock_guard lock(mu_);
    view_.params = std::move(params);
    ++view_.params_revision;
    view_.scene = std::move(scene);
    ++view_.scene_revision;
    view_.scenes = std::move(scenes.scenes);
    refetch_ = false;
  } catch (const std::exception& e) {
    std::lock_guard lock(mu_);
    view_.connection_error = e.what();
  }
}

void ServerLink::Loop() {
  Clock::time_point next_poll = Clock::now();
  for (;;) {
    std::pair<std::string, Command> job;
    {
      std::unique_lock lock(mu_);
      wake_.wait_until(lock, next_poll, [this] { return stop_ || !queue_.empty(); });
      if (stop_) return;
      if (!queue_.empty()) {
        job = std::move(queue_.front());
        queue_.pop_front();
        busy_ = true;
      }
    }
    if (job.second) {
      try {
        job.second(client_);
      } catch (const std::exception& e) {
        Note(job.first + ": " + e.what(), true);
      }
      {
        std::lock_guard lock(mu_);
        busy_ = false;
      }
      idle_.notify_all();
    }
    if (Clock::now() >= next_poll) {
      Poll();
      next_poll = Clock::now() + poll_interval_;
    }
  }
}

}  // namespace dysa::viewer
