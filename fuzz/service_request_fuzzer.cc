// libFuzzer target for the service's request handling: random and mutated protobuf requests
// through the gRPC adapter's conversions (proto_conversions.h) and a real SimulationHost, as
// simulation_service.cc handles them, without the network (input layout in service_input.h).
//
// One host per process: a small seed scene (8 particles), started paused, frame_rate 0, at most
// kHostMaxParticles particles (as dysa-server --max-particles would). Each record of an input is
// parsed as its request type (ParseFromArray; one that does not parse is dropped, as gRPC would
// drop the call), converted like the adapter does and, when it converts, submitted as a control;
// the harness waits for its ControlResult. After an input that changed the host, a Pause and a
// LoadScene of the small scene put it back, so every input starts from the same state.
//
// Checked, besides no crash, sanitizer report, leak or hang:
//   - a conversion returns OK or a status, never an exception (the adapter would turn one into
//     INTERNAL); its message is bounded and escaped, and names a field;
//   - every control is answered, within kAnswerTimeout, with a known code; a message, present
//     exactly when the code is not OK, is bounded and escaped (fuzz_checks.h);
//   - the replies build (ToProto) from what the host answers, and the host answers Status()
//     afterwards with at most kHostMaxParticles particles.
//
// To keep executions fast, a Step of 2 to kMaxStepCount frames steps 2 (larger counts are
// passed on, and refused); a Step control's caller gives it kStepDeadline.
#include <google/protobuf/stubs/logging.h>
#include <grpc/grpc.h>
#include <grpcpp/support/byte_buffer.h>
#include <grpcpp/support/slice.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <exception>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <typeinfo>
#include <utility>

#include "dysa/core/params.h"
#include "dysa/core/scene.h"
#include "dysa/service/frame_hub.h"
#include "dysa/service/simulation_host.h"
#include "fuzz_checks.h"
#include "proto_conversions.h"
#include "rpc_status.h"
#include "service_input.h"

namespace {

using dysa::fuzz::CheckSafeText;
using dysa::fuzz::Finding;
using dysa::fuzz::Request;
using dysa::fuzz::RequestKind;
using namespace dysa::service;  // NOLINT: the harness is all about this namespace

constexpr std::string_view kHarness = "service_request_fuzzer";
constexpr uint64_t kHostMaxParticles = 512;
constexpr auto kAnswerTimeout = std::chrono::seconds(60);
constexpr auto kStepDeadline = std::chrono::milliseconds(400);

constexpr std::string_view kSmallScene = R"({
  "name": "fuzz_small",
  "domain": {"min": [-1, -1, -1], "max": [1, 1, 1]},
  "fluid_blocks": [{"center": [0, 0, 0], "size": [0.4, 0.4, 0.4], "particles_per_axis": [2, 2, 2]}],
  "solver": "seed",
  "params": {"iterations_per_frame": 1, "smoothing_radius": 0.35}
})";

SimulationHost* g_host = nullptr;
dysa::Scene* g_small_scene = nullptr;

class NullListener : public FrameListener {
 public:
  void OnFrameReady() override {}
  void OnHubClosed() override {}
};

void CheckMessage(std::string_view what, const std::string& message) {
  CheckSafeText(kHarness, what, message, kMaxStatusMessageBytes);
}

// A conversion's status: OK, or INVALID_ARGUMENT with a bounded, escaped message naming a field
// ("name: ...").
void CheckConversion(std::string_view what, const grpc::Status& status) {
  if (status.ok()) return;
  if (status.error_code() != grpc::StatusCode::INVALID_ARGUMENT) {
    Finding(kHarness, std::string(what) + " answered code " +
                          std::to_string(int(status.error_code())) + ": " + status.error_message());
  }
  CheckMessage(std::string(what) + " message", status.error_message());
  if (status.error_message().find(": ") == std::string::npos) {
    Finding(kHarness, std::string(what) + " message names no field: " + status.error_message());
  }
}

// Submits `control` as the adapter does and waits for its answer.
ControlResult Apply(Control control,
                    std::chrono::steady_clock::duration patience = std::chrono::hours(24)) {
  const std::string name = ControlName(control);
  struct Answer {
    std::mutex mu;
    std::condition_variable cv;
    std::optional<ControlResult> result;
  };
  auto answer = std::make_shared<Answer>();
  ControlCaller caller;
  if (patience < std::chrono::hours(24))
    caller.deadline = std::chrono::steady_clock::now() + patience;
  g_host->Submit(
      std::move(control),
      [answer](ControlResult r) {
        std::lock_guard lock(answer->mu);
        answer->result = std::move(r);
        answer->cv.notify_one();
      },
      std::move(caller));
  std::unique_lock lock(answer->mu);
  if (!answer->cv.wait_for(lock, kAnswerTimeout, [&] { return answer->result.has_value(); })) {
    Finding(kHarness, name + " was not answered within 60 s");
  }
  ControlResult r = std::move(*answer->result);
  if (r.code > ControlCode::kCancelled) {
    Finding(kHarness, name + " answered an unknown code " + std::to_string(int(r.code)));
  }
  CheckMessage(name + " message", r.message);
  if (r.code != ControlCode::kOk && r.message.empty()) {
    Finding(kHarness, name + " failed (code " + std::to_string(int(r.code)) + ") saying nothing");
  }
  // The replies the adapter builds from it, and the status it finishes the call with.
  dysa::v1::ControlReply reply;
  ToProto(r.status, *reply.mutable_status());
  dysa::v1::UpdateParamsReply params_reply;
  ToProto(r.params, *params_reply.mutable_params());
  const grpc::Status status = ToGrpc(r.code, r.message);
  if (status.ok() != (r.code == ControlCode::kOk)) {
    Finding(kHarness, name + ": ToGrpc turned code " + std::to_string(int(r.code)) +
                          " into status " + std::to_string(int(status.error_code())));
  }
  return r;
}

template <class Message>
std::optional<Message> Parse(std::string_view bytes) {
  Message message;
  if (!message.ParseFromArray(bytes.data(), int(bytes.size()))) return std::nullopt;
  return message;
}

// The adapter runs conversions inside Guarded(): an exception is an INTERNAL error, a finding.
template <class Body>
void Converting(std::string_view what, Body&& body) {
  try {
    body();
  } catch (const std::exception& e) {
    Finding(kHarness, std::string(what) + " threw " + typeid(e).name() + ": " + e.what());
  } catch (...) {
    Finding(kHarness, std::string(what) + " threw something that is not a std::exception");
  }
}

uint32_t LeanCount(uint32_t count) {
  count = std::max(count, 1u);  // as SimulationService::Step
  return count >= 2 && count <= kMaxStepCount ? 2 : count;
}

// Handles one request; true when it may have changed the host.
bool Handle(const Request& request) {
  switch (request.kind) {
    case RequestKind::kLoadScene: {
      const auto parsed = Parse<dysa::v1::LoadSceneRequest>(request.bytes);
      if (!parsed) return false;
      LoadSceneControl control;
      grpc::Status status;
      Converting("ToControl(LoadSceneRequest)", [&] { status = ToControl(*parsed, control); });
      CheckConversion("ToControl(LoadSceneRequest)", status);
      if (!status.ok()) return false;
      return Apply(std::move(control)).code == ControlCode::kOk;
    }
    case RequestKind::kUpdateParams: {
      const auto parsed = Parse<dysa::v1::UpdateParamsRequest>(request.bytes);
      if (!parsed) return false;
      UpdateParamsControl control;
      grpc::Status status;
      Converting("ToControl(UpdateParamsRequest)", [&] { status = ToControl(*parsed, control); });
      CheckConversion("ToControl(UpdateParamsRequest)", status);
      if (!status.ok()) return false;
      return Apply(std::move(control)).code == ControlCode::kOk;
    }
    case RequestKind::kStep: {
      const auto parsed = Parse<dysa::v1::StepRequest>(request.bytes);
      if (!parsed) return false;
      return Apply(StepControl{LeanCount(parsed->count())}, kStepDeadline).code == ControlCode::kOk;
    }
    case RequestKind::kStepBack: {
      const auto parsed = Parse<dysa::v1::StepBackRequest>(request.bytes);
      if (!parsed) return false;
      return Apply(StepBackControl{std::max(parsed->count(), 1u)}).code == ControlCode::kOk;
    }
    case RequestKind::kStreamFrames: {
      // A raw method: the server hands the adapter the bytes, parsed or not.
      const grpc::Slice slice(request.bytes.data(), request.bytes.size());
      const grpc::ByteBuffer buffer(&slice, 1);
      SubscriptionOptions options;
      grpc::Status status;
      Converting("ToOptions(StreamFramesRequest)", [&] { status = ToOptions(buffer, options); });
      CheckConversion("ToOptions(StreamFramesRequest)", status);
      if (!status.ok()) return false;
      // FrameStreamReactor::Begin: subscribe (std::invalid_argument names the field), then a
      // frame is encoded for the subscriber with these settings.
      NullListener listener;
      std::shared_ptr<Subscription> subscription;
      try {
        subscription = g_host->hub().Subscribe(options, &listener);
      } catch (const SubscriberLimitError& e) {
        Finding(kHarness, std::string("Subscribe: ") + e.what());
      } catch (const std::invalid_argument& e) {
        CheckMessage("Subscribe's error", e.what());
        return false;
      } catch (const std::exception& e) {
        Finding(kHarness, std::string("Subscribe threw ") + typeid(e).name() + ": " + e.what());
      }
      const bool changed = Apply(StepControl{1}, kStepDeadline).code == ControlCode::kOk;
      uint32_t skipped = 0;
      subscription->Take(&skipped);
      g_host->hub().Unsubscribe(subscription);
      return changed;
    }
    case RequestKind::kPause:
      if (!Parse<dysa::v1::PauseRequest>(request.bytes)) return false;
      Apply(PauseControl{});
      return false;
    case RequestKind::kResume:
      if (!Parse<dysa::v1::ResumeRequest>(request.bytes)) return false;
      Apply(ResumeControl{});
      return true;
    case RequestKind::kReset:
      if (!Parse<dysa::v1::ResetRequest>(request.bytes)) return false;
      return Apply(ResetControl{}).code == ControlCode::kOk;
    case RequestKind::kRead: {
      if (!Parse<dysa::v1::GetStatusRequest>(request.bytes)) return false;
      dysa::v1::Status status;
      ToProto(g_host->Status(), status);
      dysa::v1::ParamsReply params;
      ToProto(g_host->CurrentParams(), *params.mutable_params());
      dysa::v1::SceneDescription scene;
      ToProto(g_host->CurrentScene(), scene);
      return false;
    }
    case RequestKind::kCount:
      break;
  }
  return false;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  grpc_init();  // grpc::ByteBuffer and Slice need the library
  // Protobuf logs every string field with malformed UTF-8 that fails a parse: noise, and slow.
  google::protobuf::SetLogHandler(nullptr);
  HostOptions options;
  options.start_paused = true;
  options.frame_rate = 0;
  options.max_particles = kHostMaxParticles;
  options.solver_threads = 1;
  options.history.max_bytes = size_t{4} << 20;
  g_small_scene = new dysa::Scene(dysa::ParseScene(kSmallScene));
  g_host = new SimulationHost(*g_small_scene, options);  // lives as long as the process
  g_host->Start();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  bool changed = false;
  for (const Request& request : dysa::fuzz::SplitRequests(input)) changed |= Handle(request);
  const HostStatus status = g_host->Status();
  if (status.particles > kHostMaxParticles) {
    Finding(kHarness, "the host runs " + std::to_string(status.particles) + " particles");
  }
  CheckSafeText(kHarness, "status alarm", status.alarm, kMaxLogLineBytes);
  if (changed || status.running) {
    Apply(PauseControl{});
    if (Apply(LoadSceneControl{*g_small_scene}).code != ControlCode::kOk) {
      Finding(kHarness, "the host no longer loads the small scene");
    }
  }
  return 0;
}
