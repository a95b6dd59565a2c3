// libFuzzer target for dysa::codec::FrameDecoder (fuzz/README.md; input layout in fuzz_input.h).
//
// The decoder promises to throw DecodeError, and nothing else, for malformed, truncated or hostile
// input. Any other exception, a crash, a sanitizer report or a broken invariant below is a
// finding. Invariants checked on every frame the decoder returns:
//   - array sizes agree with count and fields (positions always present);
//   - no NaN in a decoded value while the frame's error bounds are finite;
//   - in differential mode (delivery 3), AddChunks on all chunks, AddChunk one by one, and
//     AddChunks(..., Frame& out) with a recycled `out` agree (fuzz_input.h).
//
// Environment (read once):
//   DYSA_FUZZ_MAX_COUNT  inputs with a chunk header claiming more particles than this are
//                        skipped (default 65536; 0 = no limit). The decoder itself accepts up
//                        to 2^26 and allocates for them before reading any payload, which runs
//                        past libFuzzer's memory limit and would stop every run early.
//   DYSA_FUZZ_NAN        0 turns the NaN check off (default on).
//   DYSA_FUZZ_RECYCLE    0 turns off the comparison of the frames decoded into a recycled
//                        `out` (delivery 3, decoder C) with the others (default on).
//   DYSA_FUZZ_VERBOSE    1 prints each decoded frame and DecodeError (to look at a seed or a
//                        reproducer: frame_decoder_fuzzer FILE).
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <optional>
#include <span>
#include <string>
#include <typeinfo>
#include <vector>

#include "dysa/codec/frame_codec.h"
#include "fuzz_input.h"

namespace {

using dysa::codec::Chunk;
using dysa::codec::DecodeError;
using dysa::codec::Frame;
using dysa::codec::FrameDecoder;
using dysa::codec::kHeaderSize;

uint32_t g_max_count = 1u << 16;
bool g_check_nan = true;
bool g_verbose = false;
bool g_check_recycle = true;

[[noreturn]] void Finding(const std::string& what) {
  std::fprintf(stderr, "frame_decoder_fuzzer: FINDING: %s\n", what.c_str());
  std::fflush(stderr);
  std::abort();
}

bool SameBits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
}

bool SameFrame(const Frame& a, const Frame& b) {
  auto same_double = [](double x, double y) { return std::memcmp(&x, &y, sizeof x) == 0; };
  return a.frame_seq == b.frame_seq && a.step == b.step && same_double(a.time, b.time) &&
         a.keyframe == b.keyframe && a.count == b.count && a.stride == b.stride &&
         a.fields == b.fields && SameBits(a.positions, b.positions) && SameBits(a.speed, b.speed) &&
         SameBits(a.velocities, b.velocities) && SameBits(a.densities, b.densities) &&
         std::memcmp(a.position_error.data(), b.position_error.data(), sizeof a.position_error) ==
             0 &&
         same_double(a.speed_error, b.speed_error) &&
         same_double(a.velocity_error, b.velocity_error) &&
         same_double(a.density_error, b.density_error);
}

void CheckFrame(const Frame& f) {
  using namespace dysa::codec;
  const size_t n = f.count;
  auto expect_size = [&](const char* name, size_t got, size_t want) {
    if (got != want) {
      Finding(std::string(name) + " has " + std::to_string(got) + " values, expected " +
              std::to_string(want) + " (count " + std::to_string(n) + ", fields " +
              std::to_string(f.fields) + ")");
    }
  };
  if (!(f.fields & kPositions)) Finding("a frame without positions");
  expect_size("positions", f.positions.size(), 3 * n);
  expect_size("speed", f.speed.size(), (f.fields & kSpeed) ? n : 0);
  expect_size("velocities", f.velocities.size(), (f.fields & kVelocity) ? 3 * n : 0);
  expect_size("densities", f.densities.size(), (f.fields & kDensity) ? n : 0);
  if (!g_check_nan) return;
  auto check = [](const char* name, const std::vector<float>& v, double error) {
    if (!std::isfinite(error)) return;
    for (size_t i = 0; i < v.size(); ++i) {
      if (std::isnan(v[i])) {
        Finding(std::string(name) + "[" + std::to_string(i) + "] is NaN with a finite error bound");
      }
    }
  };
  const double position_error =
      std::max({f.position_error[0], f.position_error[1], f.position_error[2]});
  check("positions", f.positions, position_error);
  check("speed", f.speed, f.speed_error);
  check("velocities", f.velocities, f.velocity_error);
  check("densities", f.densities, f.density_error);
}

// Calls `decode`, letting DecodeError through as `false` (any other exception is a finding).
template <class F>
bool Guarded(F&& decode) {
  try {
    decode();
    return true;
  } catch (const DecodeError& e) {
    if (g_verbose) std::fprintf(stderr, "  DecodeError: %s\n", e.what());
    return false;
  } catch (const std::exception& e) {
    Finding(std::string("exception other than DecodeError: ") + typeid(e).name() + ": " + e.what());
  } catch (...) {
    Finding("non-standard exception");
  }
}

// Overwrites every value of a frame the caller holds, keeping the sizes.
void Scribble(Frame& f) {
  const float junk = std::bit_cast<float>(uint32_t{0x5a5a5a5a});  // 1.5e16, easy to spot
  for (auto* v : {&f.positions, &f.speed, &f.velocities, &f.densities}) {
    std::fill(v->begin(), v->end(), junk);
  }
}

// Where two frames first differ, for the report.
std::string FirstDifference(const Frame& a, const Frame& b) {
  const std::pair<const char*, const std::vector<float>*> arrays[] = {{"positions", &a.positions},
                                                                      {"speed", &a.speed},
                                                                      {"velocities", &a.velocities},
                                                                      {"densities", &a.densities}};
  const std::vector<float>* others[] = {&b.positions, &b.speed, &b.velocities, &b.densities};
  for (int i = 0; i < 4; ++i) {
    const auto& x = *arrays[i].second;
    const auto& y = *others[i];
    if (x.size() != y.size()) {
      return std::string(": ") + arrays[i].first + " sizes " + std::to_string(x.size()) + " and " +
             std::to_string(y.size());
    }
    for (size_t k = 0; k < x.size(); ++k) {
      if (std::bit_cast<uint32_t>(x[k]) != std::bit_cast<uint32_t>(y[k])) {
        char buf[160];
        std::snprintf(buf, sizeof buf, ": %s[%zu] is %a (0x%08x) and %a (0x%08x)", arrays[i].first,
                      k, double(x[k]), std::bit_cast<uint32_t>(x[k]), double(y[k]),
                      std::bit_cast<uint32_t>(y[k]));
        return buf;
      }
    }
  }
  return ": in the header fields or error bounds";
}

// The last frame a sequence of calls returned.
struct Result {
  std::optional<Frame> last;
  void Take(const Frame& f) { Take(std::optional<Frame>(f)); }
  void Take(std::optional<Frame> f) {
    if (!f) return;
    if (g_verbose) {
      std::fprintf(stderr, "  frame %u: %s, count %u, stride %u, fields %u\n", f->frame_seq,
                   f->keyframe ? "keyframe" : "delta", f->count, f->stride, f->fields);
    }
    CheckFrame(*f);
    last = std::move(f);
  }
};

bool WithinCountLimit(const std::vector<Chunk>& chunks) {
  if (g_max_count == 0) return true;
  for (const Chunk& c : chunks) {
    if (c.size() < kHeaderSize) continue;
    uint32_t count;
    std::memcpy(&count, c.data() + 12, sizeof count);
    if (count > g_max_count) return false;
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  if (const char* s = std::getenv("DYSA_FUZZ_MAX_COUNT")) g_max_count = uint32_t(std::atoll(s));
  if (const char* s = std::getenv("DYSA_FUZZ_NAN")) g_check_nan = std::atoi(s) != 0;
  if (const char* s = std::getenv("DYSA_FUZZ_VERBOSE")) g_verbose = std::atoi(s) != 0;
  if (const char* s = std::getenv("DYSA_FUZZ_RECYCLE")) g_check_recycle = std::atoi(s) != 0;
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace dysa::fuzz;
  if (size < 1) return 0;
  const uint8_t mode = data[0];
  const auto delivery = Delivery(mode & 3);
  const auto split = Split((mode >> 2) & 1);
  const size_t group = ((mode >> 3) & 7) + 1;
  const bool recycle = (mode & kRecycle) != 0;
  const std::vector<Chunk> chunks = SplitChunks(data + 1, size - 1, split);
  if (chunks.empty() || !WithinCountLimit(chunks)) return 0;
  const std::span<const Chunk> all(chunks);

  FrameDecoder decoder;
  Result result;
  Frame out;  // recycled between calls with `recycle`
  // One call on chunks [at, at + n).
  auto add = [&](size_t at, size_t n) {
    if (recycle) {
      if (decoder.AddChunks(all.subspan(at, n), out)) result.Take(out);
    } else if (n == 1 && delivery == kPerChunk) {
      result.Take(decoder.AddChunk(chunks[at]));
    } else {
      result.Take(decoder.AddChunks(all.subspan(at, n)));
    }
  };
  switch (delivery) {
    case kPerChunk:
      for (size_t k = 0; k < chunks.size(); ++k) Guarded([&] { add(k, 1); });
      break;
    case kAllAtOnce:
      Guarded([&] { add(0, chunks.size()); });
      break;
    case kGroups:
      for (size_t at = 0; at < chunks.size(); at += group) {
        Guarded([&] { add(at, std::min(group, chunks.size() - at)); });
      }
      break;
    case kDifferential: {
      const bool a_ok = Guarded([&] { result.Take(decoder.AddChunks(all)); });
      FrameDecoder b, c;
      Result b_result;
      for (size_t k = 0; k < chunks.size(); ++k) {
        std::optional<Frame> b_frame;
        const bool b_ok = Guarded([&] { b_frame = b.AddChunk(chunks[k]); });
        if (a_ok && !b_ok) {
          Finding("AddChunks accepted all chunks, AddChunk threw DecodeError on chunk " +
                  std::to_string(k));
        }
        // C: the caller's frame, scribbled over (a renderer may reuse it), must not leak into
        // the next frame decoded into its buffers.
        Scribble(out);
        bool c_done = false;
        const bool c_ok = Guarded([&] { c_done = c.AddChunks(all.subspan(k, 1), out); });
        if (b_ok != c_ok || b_frame.has_value() != c_done) {
          Finding("AddChunk and AddChunks(..., Frame&) disagree on chunk " + std::to_string(k) +
                  (b_ok != c_ok ? " (DecodeError in one only)" : " (frame returned by one only)"));
        }
        if (c_done && g_check_recycle && !SameFrame(*b_frame, out)) {
          Finding("AddChunk and AddChunks(..., Frame&) returned different frames at chunk " +
                  std::to_string(k) + FirstDifference(*b_frame, out));
        }
        if (c_done) CheckFrame(out);
        b_result.Take(std::move(b_frame));
      }
      if (a_ok && (result.last.has_value() != b_result.last.has_value() ||
                   (result.last && !SameFrame(*result.last, *b_result.last)))) {
        Finding("AddChunks and AddChunk one by one returned different frames");
      }
      if (a_ok && decoder.waiting_for_keyframe() != b.waiting_for_keyframe()) {
        Finding("AddChunks and AddChunk one by one left different waiting_for_keyframe()");
      }
      break;
    }
  }
  return 0;
}
