// The input layout of service_request_fuzzer, shared with make_service_corpus: a sequence of at
// most kMaxRequests records, each a request kind byte, a little-endian 16-bit length and that
// many bytes of the serialised request (the last record takes what is left when its length
// runs past the end).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace dysa::fuzz {

enum class RequestKind : uint8_t {
  kLoadScene,     // v1::LoadSceneRequest
  kUpdateParams,  // v1::UpdateParamsRequest
  kStep,          // v1::StepRequest
  kStepBack,      // v1::StepBackRequest
  kStreamFrames,  // v1::StreamFramesRequest (a raw method: a ByteBuffer), then a Step
  kPause,         // v1::PauseRequest
  kResume,        // v1::ResumeRequest
  kReset,         // v1::ResetRequest
  kRead,          // v1::GetStatusRequest: GetStatus, GetParams and GetScene's replies
  kCount
};

inline constexpr size_t kMaxRequests = 8;

struct Request {
  RequestKind kind;
  std::string_view bytes;
};

inline std::vector<Request> SplitRequests(std::string_view input) {
  std::vector<Request> requests;
  while (input.size() >= 3 && requests.size() < kMaxRequests) {
    const auto kind = RequestKind(uint8_t(input[0]) % uint8_t(RequestKind::kCount));
    const size_t length = uint8_t(input[1]) | size_t(uint8_t(input[2])) << 8;
    input.remove_prefix(3);
    const size_t taken = length < input.size() ? length : input.size();
    requests.push_back({kind, input.substr(0, taken)});
    input.remove_prefix(taken);
  }
  return requests;
}

inline void AppendRequest(std::string& input, RequestKind kind, const std::string& bytes) {
  input += char(kind);
  input += char(bytes.size() & 0xff);
  input += char(bytes.size() >> 8 & 0xff);
  input += bytes;
}

}  // namespace dysa::fuzz
