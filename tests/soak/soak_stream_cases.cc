// The soak cases of frame streams: subscriber churn, stalled readers, a client killed
// mid-stream (soak_cases.h).
#include <signal.h>
#include <sys/wait.h>

#include <algorithm>
#include <atomic>
#include <thread>

#include "soak/soak_cases.h"
#include "soak/soak_client.h"
#include "soak/soak_scene.h"
#include "soak/soak_server.h"

namespace dysa::soak {
namespace {

std::string MiB(double bytes) { return std::to_string(bytes / kMiB) + " MiB"; }

// Fails `result` if the memory grew by more than `bound` from `before` to `after`.
void CheckGrowth(SoakResult& result, size_t before, size_t after, size_t bound,
                 const std::string& over) {
  const double growth = double(after) - double(before);
  result.Add("rss_before", double(before) / kMiB, "MiB");
  result.Add("rss_after", double(after) / kMiB, "MiB");
  result.Add("rss_growth", growth / kMiB, "MiB");
  if (growth > double(bound)) {
    result.Fail("resident memory grew by " + MiB(growth) + " over " + over + "; the bound is " +
                MiB(double(bound)));
  }
}

// The server's subscriber count, or -1 if GetStatus failed.
int Subscribers(v1::Simulation::Stub& stub) {
  const auto status = GetStatus(stub);
  return status ? int(status->subscribers()) : -1;
}

// A stream configuration of its own for each `i` (384 of them), every field.
v1::StreamFramesRequest Configuration(int i) {
  v1::StreamFramesRequest request = EveryField();
  request.set_position_bits(1 + i % 24);
  request.set_density_bits(1 + (i / 24) % 16);
  return request;
}

}  // namespace

size_t ChurnGrowthBound() {
  const unsigned threads = std::max(2u, std::thread::hardware_concurrency());
  return 16 * kMiB + 2 * kMiB * (threads - 2);
}

SoakResult SubscriberChurn(const SoakEnv& env, const ChurnSize& size) {
  SoakResult result;
  result.case_name = "subscriber_churn";
  // 27,000 particles, paused (a stream then brings one frame), the shortest history: the stream
  // configurations are what takes memory.
  SoakServer server(env.server_binary, env.work_dir,
                    {"--scene", "seed_basic", "--paused", "--history-frames", "1",
                     "--max-subscribers", std::to_string(size.cap)});
  if (!server.running()) return result.Fail(server.error()), result;
  auto status_stub = Connect(server.address());
  int cycles_ok = 0;
  const auto cycle = [&](int i) {
    auto stub = Connect(server.address());  // and its connection, closed at the end
    auto stream = Subscribe(*stub, Configuration(i));
    if (stream->ReadFrame()) {
      ++cycles_ok;
    } else {
      result.Fail("cycle " + std::to_string(i) + ": no frame: " + stream->Close().error_message());
    }
    stream->Close();
  };
  const auto none_left = [&] {
    if (!WaitFor([&] { return Subscribers(*status_stub) == 0; }, 30)) {
      result.Fail("subscribers still open 30 s after their streams closed: " +
                  std::to_string(Subscribers(*status_stub)));
    }
  };
  // The first connection's lasting costs (the transport, the gathering buffers) are no cycle's.
  cycle(0);
  none_left();
  const size_t before = server.resident_bytes();
  for (int i = 1; i < size.cycles; ++i) cycle(i);
  none_left();

  // The cap, and one beyond.
  std::vector<std::unique_ptr<v1::Simulation::Stub>> stubs;
  std::vector<std::unique_ptr<OpenStream>> streams;
  for (int i = 0; i < size.cap; ++i) {
    stubs.push_back(Connect(server.address()));
    streams.push_back(Subscribe(*stubs.back(), Configuration(size.cycles + i)));
    if (!streams.back()->ReadFrame()) result.Fail("stream " + std::to_string(i) + " of the cap");
  }
  const int open = Subscribers(*status_stub);
  const size_t with_cap = server.resident_bytes();
  auto extra = Subscribe(*status_stub, EveryField());
  const bool extra_read = extra->ReadFrame();
  const grpc::Status refused = extra_read ? extra->Close() : extra->reader->Finish();
  if (open != size.cap) {
    result.Fail(std::to_string(open) + " subscribers with " + std::to_string(size.cap) + " open");
  }
  if (extra_read || refused.error_code() != grpc::StatusCode::RESOURCE_EXHAUSTED ||
      refused.error_message().find("subscriber limit reached: at most " +
                                   std::to_string(size.cap)) == std::string::npos) {
    result.Fail("stream " + std::to_string(size.cap + 1) +
                " not refused with RESOURCE_EXHAUSTED naming the limit: code " +
                std::to_string(int(refused.error_code())) + ": " + refused.error_message());
  }
  for (auto& stream : streams) stream->Close();
  streams.clear();
  stubs.clear();
  none_left();
  // Answering still, and taking a subscriber again below the cap.
  auto again = Subscribe(*status_stub, EveryField());
  if (!again->ReadFrame()) result.Fail("no stream after the cap's streams closed");
  again->Close();
  none_left();
  const size_t after = server.resident_bytes();
  result.Add("cycles", cycles_ok);
  result.Add("cap", size.cap);
  result.Add("rss_with_cap_open", double(with_cap) / kMiB, "MiB");
  CheckGrowth(result, before, after, size.max_growth,
              std::to_string(size.cycles) + " subscribe/disconnect cycles and " +
                  std::to_string(size.cap) + " streams at once");
  return result;
}

SoakResult StalledReaders(const SoakEnv& env, const StalledSize& size) {
  SoakResult result;
  result.case_name = "stalled_readers";
  // 8,000 particles: cheap to step at the frame rate on one thread, frames of about 100 KB that
  // fill a reader's transport window within a few frames.
  SoakServer server(env.server_binary, env.work_dir,
                    {"--scene", WriteScene(env.work_dir, "soak", 20), "--frame-rate",
                     std::to_string(size.frame_rate), "--history-frames", "30"});
  if (!server.running()) return result.Fail(server.error()), result;
  auto stub = Connect(server.address());
  // Frames per wall second over `seconds`, from the server's frame counter.
  const auto frame_rate = [&](double seconds) {
    const auto first = GetStatus(*stub);
    const auto start = std::chrono::steady_clock::now();
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    const auto last = GetStatus(*stub);
    const double wall = SecondsSince(start);
    return first && last ? double(last->frame() - first->frame()) / wall : 0.0;
  };
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // past the start-up
  const double baseline = frame_rate(std::max(2.0, size.seconds / 2));

  std::vector<std::unique_ptr<v1::Simulation::Stub>> stubs;
  std::vector<std::unique_ptr<OpenStream>> streams;
  for (int i = 0; i < size.readers; ++i) {
    stubs.push_back(Connect(server.address()));
    streams.push_back(Subscribe(*stubs.back(), EveryField()));
    if (!streams.back()->ReadFrame()) result.Fail("reader " + std::to_string(i) + ": no frame");
  }
  // GetStatus all along, on a connection of its own.
  std::atomic<bool> stalled = true;
  std::atomic<int> status_calls = 0, status_failures = 0;
  std::atomic<double> slowest_status = 0;
  std::thread watcher([&] {
    auto watch = Connect(server.address());
    while (stalled) {
      const auto start = std::chrono::steady_clock::now();
      const auto status = GetStatus(*watch, 5);
      slowest_status = std::max(slowest_status.load(), SecondsSince(start));
      ++status_calls;
      if (!status || int(status->subscribers()) != size.readers) ++status_failures;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  });
  const double during = frame_rate(size.seconds);
  stalled = false;
  watcher.join();

  // Reading again: each reader is told of the frames it missed.
  int readers_skipping = 0;
  for (auto& stream : streams) {
    uint64_t skipped = 0;
    const auto start = std::chrono::steady_clock::now();
    v1::FrameMessage message;
    while (skipped == 0 && SecondsSince(start) < 30 && stream->reader->Read(&message)) {
      skipped += message.frames_skipped();
    }
    readers_skipping += skipped > 0;
    stream->Close();
  }
  result.Add("readers", size.readers);
  result.Add("stalled_seconds", size.seconds, "s");
  result.Add("fps_baseline", baseline, "1/s");
  result.Add("fps_stalled", during, "1/s");
  result.Add("status_calls", status_calls);
  result.Add("status_failures", status_failures);
  result.Add("slowest_status", slowest_status * 1000, "ms");
  result.Add("readers_skipping", readers_skipping);
  if (baseline <= 0) result.Fail("no frame simulated without subscribers");
  if (during < (1 - size.max_slowdown) * baseline) {
    result.Fail("the simulation slowed from " + std::to_string(baseline) + " to " +
                std::to_string(during) + " frames per second with stalled readers; at most " +
                std::to_string(int(size.max_slowdown * 100)) + "% slower allowed");
  }
  if (status_failures > 0 || status_calls == 0) {
    result.Fail(std::to_string(status_failures) + " of " + std::to_string(status_calls) +
                " GetStatus calls failed or miscounted the subscribers while the readers stalled");
  }
  if (readers_skipping != size.readers) {
    result.Fail("only " + std::to_string(readers_skipping) + " of " + std::to_string(size.readers) +
                " readers skipped frames: the others never stalled the server's writes");
  }
  return result;
}

SoakResult ClientKilledMidStream(const SoakEnv& env, const KilledClientSize& size) {
  SoakResult result;
  result.case_name = "client_killed_mid_stream";
  SoakServer server(env.server_binary, env.work_dir,
                    {"--scene", WriteScene(env.work_dir, "soak", 20), "--frame-rate", "30",
                     "--history-frames", "30"});
  if (!server.running()) return result.Fail(server.error()), result;
  auto stub = Connect(server.address());
  size_t before = 0;
  double slowest_release = 0;
  int killed = 0;
  for (int i = 0; i < size.cycles; ++i) {
    const pid_t client =
        SpawnProcess(env.cli_binary, {"--server", server.address(), "watch", "--seconds", "600"},
                     env.work_dir / "watch.log");
    if (!WaitFor([&] { return Subscribers(*stub) == 1; }, 30)) {
      kill(client, SIGKILL);
      waitpid(client, nullptr, 0);
      result.Fail("cycle " + std::to_string(i) + ": dysa watch never subscribed (subscribers " +
                  std::to_string(Subscribers(*stub)) + ")");
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));  // frames flowing
    if (i % 2 == 1) {
      // Stopped: it reads nothing, and the server's writes to it back up.
      kill(client, SIGSTOP);
      std::this_thread::sleep_for(std::chrono::seconds(1));
    }
    kill(client, SIGKILL);
    waitpid(client, nullptr, 0);
    ++killed;
    const auto start = std::chrono::steady_clock::now();
    if (!WaitFor([&] { return Subscribers(*stub) == 0; }, size.release_seconds)) {
      result.Fail("cycle " + std::to_string(i) + ": the killed client's stream still open " +
                  std::to_string(size.release_seconds) + " s later (subscribers " +
                  std::to_string(Subscribers(*stub)) + ")");
      break;
    }
    slowest_release = std::max(slowest_release, SecondsSince(start));
    // After a plain and a stopped client, and a second of frames (the history is full).
    if (i == 1) before = server.resident_bytes();
  }
  const auto status = GetStatus(*stub);
  if (!status) result.Fail("GetStatus failed after the killed clients");
  const size_t after = server.resident_bytes();
  result.Add("clients_killed", killed);
  result.Add("slowest_release", slowest_release * 1000, "ms");
  if (size.cycles > 2 && killed == size.cycles) {
    CheckGrowth(result, before, after, size.max_growth,
                std::to_string(size.cycles) + " killed clients");
  }
  return result;
}

}  // namespace dysa::soak
