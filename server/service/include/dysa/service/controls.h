// The controls a client sends the simulation thread (SimulationHost::Submit), and their answers.
// No RPC types: the gRPC adapter (simulation_service.cc) converts requests into Controls and
// ControlResults back into replies.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "dysa/core/params.h"
#include "dysa/core/scene.h"
#include "dysa/service/host_status.h"

namespace dysa::service {

// Controls, applied between two solver steps.
struct PauseControl {};
struct ResumeControl {};
// Runs `count` frames, then pauses; answered when they are done, or earlier, with the frames it
// moved, when another control but a parameter change arrives (which is then applied), when the
// caller is about to stop waiting (kReplyMargin before its deadline) or has gone, or when the
// simulation diverges. A parameter change is applied between its steps and the Step goes on.
struct StepControl {
  uint32_t count = 1;  // frames
};
struct StepBackControl {
  uint32_t count = 1;  // frames
};
struct ResetControl {};
struct UpdateParamsControl {
  std::vector<std::pair<std::string, double>> values;  // name, value in the declared unit
};
struct LoadSceneControl {
  Scene scene;  // parsed and validated by the caller (ParseScene/LoadScene)
};
using Control = std::variant<PauseControl, ResumeControl, StepControl, StepBackControl,
                             ResetControl, UpdateParamsControl, LoadSceneControl>;

// "Pause", "Step", ...: for the log.
const char* ControlName(const Control& control);

// Frames one Step control may advance at most (the thread does nothing else meanwhile).
inline constexpr uint32_t kMaxStepCount = 10000;

enum class ControlCode {
  kOk,
  kInvalidArgument,
  kResourceExhausted,
  kFailedPrecondition,
  kUnavailable,
  kDeadlineExceeded,  // not applied: the caller's deadline passed (or left no time to answer)
  kCancelled          // not applied (or a Step ended): the caller cancelled the call
};

// The caller waiting for a control's answer, as the simulation thread sees it when it gets to
// the control.
struct ControlCaller {
  // When the caller stops waiting for the answer; max(): never.
  std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max();
  // True once the caller has gone (it cancelled the call, or its connection broke); empty: never
  // goes. Called on the simulation thread, before the control is answered.
  std::function<bool()> cancelled;
};

// A control is applied only while at least this much is left before its caller's deadline, so
// that the answer of a control applied reaches the caller in time (a control that is applied is
// reported applied); with less left, it is answered kDeadlineExceeded and not applied. A Step
// ends this long before its caller's deadline, answered with the frames it moved.
inline constexpr std::chrono::milliseconds kReplyMargin{100};

// Why `caller` no longer waits for an answer at `now` (kOk while it does): a control is applied
// only with kReplyMargin left for its answer to arrive.
ControlCode CallerGone(const ControlCaller& caller, std::chrono::steady_clock::time_point now);

struct ControlResult {
  ControlCode code = ControlCode::kOk;
  std::string message;  // for errors: names the field and its allowed range
  bool reset = false;   // the fluid was re-spawned
  uint32_t frames_moved = 0;
  HostStatus status;  // after the control
  Params params;      // after the control
};

ControlResult ControlError(ControlCode code, std::string message);

}  // namespace dysa::service
