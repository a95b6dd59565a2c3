// The soak cases of controls and scenes: the RPC soak, the hostile scenes, SIGTERM under load.
// The stream cases are in soak_stream_cases.cc.
#include "soak/soak_cases.h"

#include <signal.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <thread>

#include "soak/soak_client.h"
#include "soak/soak_scene.h"
#include "soak/soak_server.h"

namespace dysa::soak {

std::string SoakResult::Summary() const {
  std::string text;
  for (const Figure& f : figures) {
    char value[64];
    std::snprintf(value, sizeof value, "%.6g", f.value);
    text +=
        (text.empty() ? "" : ", ") + f.name + "=" + value + (f.unit.empty() ? "" : " " + f.unit);
  }
  return text;
}

namespace {

std::string Describe(const grpc::Status& s) {
  return "code " + std::to_string(int(s.error_code())) + ": " + s.error_message().substr(0, 300);
}

// The parameter each thread of the RPC soak owns, none re-spawning the fluid: a value it sets
// stays set until it sets another (or a scene loads), and comes back in the reply.
struct OwnedParam {
  const char* name;
  double base, step;
};
constexpr OwnedParam kOwnedParams[] = {{"viscosity", 0.001, 0.0001},
                                       {"gravity", -10, 0.05},
                                       {"collision_damping", 0.086, 0.001},
                                       {"time_scale", 1, 0.01}};

// Failures of many threads, the first few kept whole.
class FailureLog {
 public:
  void Add(const std::string& what) {
    std::lock_guard lock(mu_);
    ++count_;
    if (kept_.size() < 10) kept_.push_back(what);
  }
  int count() const {
    std::lock_guard lock(mu_);
    return count_;
  }
  void CopyTo(SoakResult& result, const std::string& prefix) const {
    std::lock_guard lock(mu_);
    for (const std::string& what : kept_) result.Fail(prefix + what);
    if (count_ > int(kept_.size())) {
      result.Fail(prefix + std::to_string(count_ - kept_.size()) + " more");
    }
  }

 private:
  mutable std::mutex mu_;
  int count_ = 0;
  std::vector<std::string> kept_;
};

// One RPC of the mix, the `k`-th of thread `t`; checks what its reply says was done.
void MixedRpc(v1::Simulation::Stub& stub, int t, int k, FailureLog& failures) {
  const auto check = [&](const std::string& rpc, const grpc::Status& s, bool effect,
                         const std::string& expected) {
    if (!s.ok()) {
      failures.Add(rpc + " failed: " + Describe(s));
    } else if (!effect) {
      failures.Add(rpc + " was accepted but its reply does not show " + expected);
    }
  };
  constexpr double kSeconds = 30;
  v1::ControlReply control;
  switch ((k + t) % 10) {
    case 0: {
      v1::Status status;
      grpc::Status s = stub.GetStatus(Context(kSeconds).get(), {}, &status);
      check("GetStatus", s, status.particles() > 0, "particles");
      break;
    }
    case 1: {
      v1::ParamsReply params;
      grpc::Status s = stub.GetParams(Context(kSeconds).get(), {}, &params);
      check("GetParams", s, params.params_size() > 0, "the parameters");
      break;
    }
    case 2: {
      const OwnedParam& param = kOwnedParams[t % 4];
      const double value = param.base + param.step * (k % 10);
      v1::UpdateParamsRequest update;
      (*update.mutable_params()->mutable_values())[param.name] = value;
      v1::UpdateParamsReply reply;
      grpc::Status s = stub.UpdateParams(Context(kSeconds).get(), update, &reply);
      bool set = false;
      for (const v1::ParamInfo& info : reply.params()) {
        set |= info.name() == param.name && info.value() == value;
      }
      check("UpdateParams", s, set, std::string(param.name) + " = " + std::to_string(value));
      break;
    }
    case 3: {
      grpc::Status s = stub.Pause(Context(kSeconds).get(), {}, &control);
      check("Pause", s, control.status().state() == v1::RUN_STATE_PAUSED, "a paused simulation");
      break;
    }
    case 4: {
      grpc::Status s = stub.Resume(Context(kSeconds).get(), {}, &control);
      check("Resume", s, control.status().state() == v1::RUN_STATE_RUNNING, "a running simulation");
      break;
    }
    case 5: {
      v1::StepRequest step;
      step.set_count(1 + k % 3);
      grpc::Status s = stub.Step(Context(kSeconds).get(), step, &control);
      check("Step", s,
            control.status().state() == v1::RUN_STATE_PAUSED &&
                control.frames_moved() <= step.count(),
            "a paused simulation and at most " + std::to_string(step.count()) + " frames moved");
      break;
    }
    case 6: {
      v1::ListScenesReply scenes;
      grpc::Status s = stub.ListScenes(Context(kSeconds).get(), {}, &scenes);
      check("ListScenes", s, scenes.scenes_size() > 0 && !scenes.current().empty(), "scenes");
      break;
    }
    case 7: {
      v1::SceneDescription scene;
      grpc::Status s = stub.GetScene(Context(kSeconds).get(), {}, &scene);
      check("GetScene", s, !scene.name().empty() && scene.particle_radius() > 0, "the scene");
      break;
    }
    case 8: {
      const std::string name = "soak_t" + std::to_string(t);
      v1::LoadSceneRequest load;
      load.set_json_text(SceneText(name, 10));
      grpc::Status s = stub.LoadScene(Context(kSeconds).get(), load, &control);
      check("LoadScene", s,
            control.status().scene() == name && control.status().particles() == 1000,
            "scene " + name + " with 1000 particles");
      break;
    }
    default: {
      v1::StepBackRequest back;
      back.set_count(1);
      grpc::Status s = stub.StepBack(Context(kSeconds).get(), back, &control);
      check("StepBack", s, control.frames_moved() <= 1, "at most 1 frame moved");
      break;
    }
  }
}

// `rpcs` mixed RPCs spread over `threads` threads, each on a connection of its own.
void RunMix(const std::string& address, int rpcs, int threads, FailureLog& failures) {
  std::vector<std::thread> workers;
  for (int t = 0; t < threads; ++t) {
    workers.emplace_back([&, t] {
      auto stub = Connect(address);
      for (int k = t; k < rpcs; k += threads) MixedRpc(*stub, t, k / threads, failures);
    });
  }
  for (std::thread& worker : workers) worker.join();
}

}  // namespace

SoakResult RpcSoak(const SoakEnv& env, const RpcSoakSize& size) {
  SoakResult result;
  result.case_name = "rpc_soak";
  // 1,000 particles, a short history: neither the solver nor the history's growth hides a leak.
  SoakServer server(env.server_binary, env.work_dir,
                    {"--scene", WriteScene(env.work_dir, "soak", 10), "--history-frames", "30"});
  if (!server.running()) return result.Fail(server.error()), result;
  FailureLog failures;
  // A warm-up round: every RPC and every thread's connection has been made, and gRPC's and the
  // allocator's lasting structures exist, before memory is measured.
  const int warm_up = std::max(size.threads * 10 * 4, size.rpcs / 10);
  RunMix(server.address(), warm_up, size.threads, failures);
  const size_t before = server.resident_bytes();
  const auto start = std::chrono::steady_clock::now();
  RunMix(server.address(), size.rpcs, size.threads, failures);
  const double seconds = SecondsSince(start);
  const size_t after = server.resident_bytes();
  const double growth = double(after) - double(before);
  result.Add("rpcs", size.rpcs);
  result.Add("threads", size.threads);
  result.Add("errors", failures.count());
  result.Add("seconds", seconds, "s");
  result.Add("rpcs_per_second", size.rpcs / seconds, "1/s");
  result.Add("rss_before", double(before) / kMiB, "MiB");
  result.Add("rss_after", double(after) / kMiB, "MiB");
  result.Add("rss_growth", growth / kMiB, "MiB");
  failures.CopyTo(result, "");
  if (growth > double(size.max_growth)) {
    result.Fail("resident memory grew by " + std::to_string(growth / kMiB) + " MiB over " +
                std::to_string(size.rpcs) + " RPCs; the bound is " +
                std::to_string(size.max_growth / kMiB) + " MiB");
  }
  if (!GetStatus(*Connect(server.address()))) result.Fail("GetStatus failed after the soak");
  return result;
}

SoakResult HostileScenes(const SoakEnv& env, const HostileSize& size) {
  SoakResult result;
  result.case_name = "hostile_scenes";
  SoakServer server(env.server_binary, env.work_dir,
                    {"--scene", WriteScene(env.work_dir, "soak", 10), "--frame-rate", "30"});
  if (!server.running()) return result.Fail(server.error()), result;
  auto stub = Connect(server.address());
  const std::optional<v1::Status> before = GetStatus(*stub);
  if (!before) return result.Fail("GetStatus failed"), result;
  struct Hostile {
    std::string what, text, field;
  };
  const std::vector<Hostile> scenes = {
      {"a block crowding one grid cell",
       R"({"fluid_blocks": [{"particles_per_axis": [200, 200, 1], "size": 1e-6}]})",
       "fluid_blocks[0]: about 40000 particles"},
      {"a number a double cannot hold", R"({"params": {"viscosity": 1e999}})",
       "params.viscosity: 1e999 is out of the range of a double"},
      {"a particle count past the limit",
       R"({"fluid_blocks": [{"particles_per_axis": [100000, 100000, 100000], "size": 1000}]})",
       "fluid_blocks[0]: the scene would have"},
      {"a 4 MB name", R"({"name": ")" + std::string(4'000'000, 'N') + "\"}",
       "name: at most 256 bytes"},
      {"nesting 40 deep", R"({"fluid_blocks": [{"size": )" + std::string(40, '[') + "}]}",
       "nested deeper than 32 levels"},
  };
  int refused = 0;
  for (int round = 0; round < size.rounds; ++round) {
    for (const Hostile& hostile : scenes) {
      v1::LoadSceneRequest load;
      load.set_json_text(hostile.text);
      v1::ControlReply reply;
      const grpc::Status s = stub->LoadScene(Context(30).get(), load, &reply);
      const std::string& message = s.error_message();
      if (s.error_code() != grpc::StatusCode::INVALID_ARGUMENT ||
          message.find(hostile.field) == std::string::npos || message.size() > 2048) {
        result.Fail(hostile.what + ": expected INVALID_ARGUMENT naming '" + hostile.field +
                    "' in at most 2 KiB, got " + Describe(s) + " (" +
                    std::to_string(message.size()) + " bytes)");
      } else {
        ++refused;
      }
    }
  }
  result.Add("refused", refused);
  const std::optional<v1::Status> after = GetStatus(*stub);
  if (!after) return result.Fail("GetStatus failed after the hostile scenes"), result;
  if (after->scene() != before->scene() || after->particles() != before->particles() ||
      after->scene_version() != before->scene_version()) {
    result.Fail("the running scene changed: " + before->scene() + " (" +
                std::to_string(before->particles()) + " particles, version " +
                std::to_string(before->scene_version()) + ") became " + after->scene() + " (" +
                std::to_string(after->particles()) + ", version " +
                std::to_string(after->scene_version()) + ")");
  }
  // Still running: frames go on.
  const uint64_t frame = after->frame();
  if (!WaitFor(
          [&] {
            auto now = GetStatus(*stub);
            return now && now->frame() > frame;
          },
          30)) {
    result.Fail("no frame simulated within 30 s of the hostile scenes");
  }
  result.Add("frames_per_second", after->frames_per_second(), "1/s");
  return result;
}

SoakResult SigtermUnderLoad(const SoakEnv& env, const SigtermSize& size) {
  SoakResult result;
  result.case_name = "sigterm_under_load";
  // 27,000 particles as fast as the solver goes: a step is always in progress.
  SoakServer server(env.server_binary, env.work_dir,
                    {"--scene", "seed_basic", "--frame-rate", "0", "--history-frames", "30"});
  if (!server.running()) return result.Fail(server.error()), result;
  std::atomic<bool> stop = false;
  std::atomic<int> rpcs = 0;
  // Streams: the even ones read every frame, the odd ones one frame and then nothing.
  std::vector<std::unique_ptr<v1::Simulation::Stub>> stream_stubs;
  std::vector<std::unique_ptr<OpenStream>> streams;
  std::vector<std::thread> threads;
  for (int i = 0; i < size.streams; ++i) {
    stream_stubs.push_back(Connect(server.address()));
    streams.push_back(Subscribe(*stream_stubs.back(), EveryField()));
    if (!streams.back()->ReadFrame()) result.Fail("stream " + std::to_string(i) + " ended early");
    if (i % 2 == 0) {
      threads.emplace_back([&stream = *streams.back()] {
        while (stream.ReadFrame()) {
        }
      });
    }
  }
  for (int t = 0; t < size.rpc_threads; ++t) {
    threads.emplace_back([&, t] {
      auto stub = Connect(server.address());
      for (int k = 0; !stop; ++k) {
        v1::ControlReply control;
        grpc::Status s;
        if (t == 0 && k == 0) {
          v1::StepRequest step;  // minutes of work: in progress when the signal comes
          step.set_count(10000);
          s = stub->Step(Context(60).get(), step, &control);
        } else if (k % 3 == 0) {
          v1::UpdateParamsRequest update;
          (*update.mutable_params()->mutable_values())["viscosity"] = 0.001 + 0.0001 * (k % 7);
          v1::UpdateParamsReply reply;
          s = stub->UpdateParams(Context(10).get(), update, &reply);
        } else {
          v1::Status status;
          s = stub->GetStatus(Context(10).get(), {}, &status);
        }
        if (s.ok()) ++rpcs;
        if (!s.ok() && !stop) std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
    });
  }
  std::this_thread::sleep_for(std::chrono::duration<double>(size.load_seconds));
  const int rpcs_before_signal = rpcs;
  int exit_status = -1;
  const double seconds = server.StopTimed(SIGTERM, 30, exit_status);
  stop = true;
  for (size_t i = 1; i < streams.size(); i += 2) streams[i]->context.TryCancel();
  for (std::thread& thread : threads) thread.join();
  for (auto& stream : streams) stream->Close();
  result.Add("streams", size.streams);
  result.Add("rpcs_during_load", rpcs_before_signal);
  result.Add("seconds_to_exit", seconds, "s");
  result.Add("exit_status", exit_status);
  if (rpcs_before_signal == 0) result.Fail("no RPC was answered under load: no load to test");
  if (exit_status != 0)
    result.Fail("dysa-server exited with status " + std::to_string(exit_status));
  if (seconds >= size.max_seconds) {
    result.Fail("dysa-server took " + std::to_string(seconds) +
                " s to exit after SIGTERM; at most " + std::to_string(size.max_seconds) + " s");
  }
  return result;
}

}  // namespace dysa::soak
