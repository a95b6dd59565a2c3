#include "dysa/codec/frame_codec.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include "codec/frame_codec_test_util.h"

namespace dysa::codec {
namespace {

using ::testing::HasSubstr;
using testing::Input;
using testing::SyntheticFrames;

constexpr uint32_t kAllFields = kPositions | kSpeed | kVelocity | kDensity;

// Every decoded value of `frame` lies within the frame's stated error bound of the original.
void ExpectWithinBounds(const Frame& frame, const std::vector<float>& positions,
                        const std::vector<float>& velocities, const std::vector<float>& densities) {
  double worst[4] = {0, 0, 0, 0};
  for (uint32_t k = 0; k < frame.count; ++k) {
    const size_t i = size_t(k) * frame.stride;
    for (int a = 0; a < 3; ++a) {
      const double err = std::abs(double(frame.positions[3 * k + a]) - positions[3 * i + a]);
      ASSERT_LE(err, frame.position_error[a]) << "particle " << i << " axis " << a;
      worst[0] = std::max(worst[0], err / frame.position_error[a]);
    }
    const double vx = velocities[3 * i], vy = velocities[3 * i + 1], vz = velocities[3 * i + 2];
    if (frame.fields & kSpeed) {
      const double speed = std::sqrt(vx * vx + vy * vy + vz * vz);
      ASSERT_LE(std::abs(frame.speed[k] - speed), frame.speed_error) << "particle " << i;
    }
    if (frame.fields & kVelocity) {
      for (int a = 0; a < 3; ++a) {
        ASSERT_LE(std::abs(double(frame.velocities[3 * k + a]) - velocities[3 * i + a]),
                  frame.velocity_error);
      }
    }
    if (frame.fields & kDensity) {
      ASSERT_LE(std::abs(double(frame.densities[k]) - densities[i]), frame.density_error);
    }
  }
  // The bound is tight: some value uses most of it (a loose bound would hide bad quantising).
  EXPECT_GT(worst[0], 0.5);
}

Frame DecodeAll(FrameDecoder& decoder, const std::vector<Chunk>& chunks) {
  std::optional<Frame> frame = decoder.AddChunks(chunks);
  EXPECT_TRUE(frame.has_value());
  return frame ? *frame : Frame{};
}

TEST(FrameCodecTest, KeyframeRoundTripsWithinTheStatedBounds) {
  SyntheticFrames source(5000);
  std::vector<float> x, v, rho;
  source.Make(0, x, v, rho);
  StreamConfig config;
  config.fields = kAllFields;
  FrameEncoder encoder(config);
  FrameDecoder decoder;
  const Frame frame = DecodeAll(decoder, encoder.Encode(Input(x, v, rho, 7, 0.25)));
  EXPECT_TRUE(frame.keyframe);
  EXPECT_EQ(frame.count, 5000u);
  EXPECT_EQ(frame.step, 7u);
  EXPECT_EQ(frame.time, 0.25);
  // 16 bits over the 10 m domain: half a step is 10 / 65535 / 2 m.
  EXPECT_NEAR(frame.position_error[0], 10.0 / 65535 / 2, 1e-6);
  ExpectWithinBounds(frame, x, v, rho);
}

TEST(FrameCodecTest, DeltaFramesStayWithinBoundsAndDoNotDrift) {
  SyntheticFrames source(4000);
  StreamConfig config;
  config.fields = kAllFields;
  FrameEncoder encoder(config);
  FrameDecoder decoder;
  std::vector<float> x, v, rho;
  for (int f = 0; f < 40; ++f) {
    source.Make(f, x, v, rho);
    const Frame frame = DecodeAll(decoder, encoder.Encode(Input(x, v, rho, f, f / 60.0)));
    EXPECT_EQ(frame.keyframe, f == 0) << "frame " << f;
    ExpectWithinBounds(frame, x, v, rho);
  }
}

TEST(FrameCodecTest, DeltaFramesAreSmallerThanKeyframes) {
  SyntheticFrames source(20000);
  FrameEncoder encoder(StreamConfig{});
  std::vector<float> x, v, rho;
  size_t key = 0, delta = 0;
  for (int f = 0; f < 5; ++f) {
    source.Make(f, x, v, rho);
    size_t bytes = 0;
    for (const Chunk& c : encoder.Encode(Input(x, v, rho, f, f / 60.0))) bytes += c.size();
    (f == 0 ? key : delta) = bytes;
  }
  EXPECT_LT(delta, key * 3 / 4) << "key " << key << " delta " << delta;
}

TEST(FrameCodecTest, OctahedralVelocityStaysWithinItsBoundInKeyAndDeltaFrames) {
  SyntheticFrames source(6000);
  StreamConfig config;
  config.fields = kPositions | kVelocity;
  config.velocity_encoding = VelocityEncoding::kOctahedral;
  FrameEncoder encoder(config);
  FrameDecoder decoder;
  std::vector<float> x, v, rho;
  double worst_angle = 0;
  for (int f = 0; f < 12; ++f) {
    source.Make(f, x, v, rho);
    const Frame frame = DecodeAll(decoder, encoder.Encode(Input(x, v, rho, f, f / 60.0)));
    EXPECT_EQ(frame.keyframe, f == 0);
    EXPECT_EQ(frame.velocity_encoding, VelocityEncoding::kOctahedral);
    ExpectWithinBounds(frame, x, v, rho);
    // The direction error is relative: slow particles keep their direction as well as fast ones.
    for (uint32_t k = 0; k < frame.count; ++k) {
      double dot = 0, aa = 0, bb = 0;
      for (int c = 0; c < 3; ++c) {
        const double a = v[3 * k + c], b = frame.velocities[3 * k + c];
        dot += a * b, aa += a * a, bb += b * b;
      }
      if (aa < 0.05 * 0.05) continue;
      worst_angle = std::max(worst_angle, std::acos(std::min(1.0, dot / std::sqrt(aa * bb))));
    }
  }
  // 12 bits: the octahedral cells are 2 / 4095 wide, under 0.1 degrees of arc near the poles.
  EXPECT_LT(worst_angle, 0.003);
  EXPECT_GT(worst_angle, 0.0);
}

TEST(FrameCodecTest, OctahedralVelocityOfEveryDirectionAndOfZero) {
  // Directions over the whole sphere, both hemispheres, the fold lines (a zero x, y or z) and
  // the zero vector; magnitudes over four decades.
  std::vector<float> x, v, rho;
  for (int i = 0; i < 27 * 4; ++i) {
    const int d = i % 27;
    const double scale = std::pow(10.0, i / 27 - 2);
    for (int a = 0; a < 3; ++a) v.push_back(float(scale * ((d / int(std::pow(3, a))) % 3 - 1)));
    for (int a = 0; a < 3; ++a) x.push_back(float(i % 7 - a));
  }
  rho.assign(x.size() / 3, 1000.0f);
  StreamConfig config;
  config.fields = kPositions | kSpeed | kVelocity;
  config.velocity_encoding = VelocityEncoding::kOctahedral;
  FrameEncoder encoder(config);
  FrameDecoder decoder;
  const Frame frame = DecodeAll(decoder, encoder.Encode(Input(x, v, rho, 0, 0)));
  for (uint32_t k = 0; k < frame.count; ++k) {
    for (int a = 0; a < 3; ++a) {
      ASSERT_LE(std::abs(frame.velocities[3 * k + a] - v[3 * k + a]), frame.velocity_error)
          << "particle " << k << " component " << a;
      // Signs survive the fold: a component decodes with the sign it had (or as about 0).
      if (std::abs(v[3 * k + a]) > 2 * frame.velocity_error) {
        EXPECT_EQ(std::signbit(frame.velocities[3 * k + a]), std::signbit(v[3 * k + a]));
      }
    }
  }
  // The zero vector (particle 13 of each block of 27) decodes as exactly zero.
  for (int a = 0; a < 3; ++a) EXPECT_EQ(frame.velocities[3 * 13 + a], 0.0f);
}

TEST(FrameCodecTest, KeyframeEveryIntervalAndOnRequest) {
  SyntheticFrames source(500);
  StreamConfig config;
  config.keyframe_interval = 3;
  FrameEncoder encoder(config);
  FrameDecoder decoder;
  std::vector<float> x, v, rho;
  std::vector<bool> keys;
  for (int f = 0; f < 8; ++f) {
    if (f == 4) encoder.RequestKeyframe();
    source.Make(f, x, v, rho);
    keys.push_back(DecodeAll(decoder, encoder.Encode(Input(x, v, rho, f, f / 60.0))).keyframe);
  }
  EXPECT_EQ(keys, (std::vector<bool>{true, false, false, true, true, false, false, true}));
}

TEST(FrameCodecTest, ValueLeavingItsRangeForcesAKeyframe) {
  SyntheticFrames source(300);
  std::vector<float> x, v, rho;
  FrameEncoder encoder(StreamConfig{});
  FrameDecoder decoder;
  source.Make(0, x, v, rho);
  DecodeAll(decoder, encoder.Encode(Input(x, v, rho, 0, 0)));
  for (float& c : v) c *= 10;  // speeds far beyond the keyframe's range
  const Frame frame = DecodeAll(decoder, encoder.Encode(Input(x, v, rho, 1, 0.1)));
  EXPECT_TRUE(frame.keyframe);
  ExpectWithinBounds(frame, x, v, rho);
}

// In a periodic domain a particle leaving through one face comes back through the opposite
// one: between two frames it jumps the domain's length, far from the delta prediction. The
// frames still decode within their bounds, delta frames or keyframes alike, and the next frames
// too (the prediction restarts from the jump).
TEST(FrameCodecTest, ParticlesWrappingAroundAPeriodicDomainStayWithinBounds) {
  SyntheticFrames source(500);
  std::vector<float> x, v, rho;
  FrameEncoder encoder(StreamConfig{});
  FrameDecoder decoder;
  for (int f = 0; f < 6; ++f) {
    source.Make(f, x, v, rho);
    if (f >= 3) {
      for (uint32_t i = 0; i < 500; i += 7) x[3 * i] += x[3 * i] < 0 ? 9.9f : -9.9f;  // wrapped
    }
    const Frame frame = DecodeAll(decoder, encoder.Encode(Input(x, v, rho, f, f / 60.0)));
    SCOPED_TRACE("frame " + std::to_string(f));
    ExpectWithinBounds(frame, x, v, rho);
  }
}

TEST(FrameCodecTest, StrideKeepsEveryNthParticleById) {
  SyntheticFrames source(1000);
  std::vector<float> x, v, rho;
  source.Make(3, x, v, rho);
  StreamConfig config;
  config.stride = 3;
  FrameEncoder encoder(config);
  FrameDecoder decoder;
  const Frame frame = DecodeAll(decoder, encoder.Encode(Input(x, v, rho, 0, 0)));
  EXPECT_EQ(frame.count, 334u);
  EXPECT_EQ(frame.stride, 3u);
  ExpectWithinBounds(frame, x, v, rho);
}

TEST(FrameCodecTest, ChunksArriveOneByOneAndInAnyOrder) {
  SyntheticFrames source(1000);
  std::vector<float> x, v, rho;
  StreamConfig config;
  config.chunk_particles = 128;
  FrameEncoder encoder(config);
  FrameDecoder decoder;
  for (int f = 0; f < 3; ++f) {
    source.Make(f, x, v, rho);
    std::vector<Chunk> chunks = encoder.Encode(Input(x, v, rho, f, f / 60.0));
    ASSERT_EQ(chunks.size(), 8u);
    std::reverse(chunks.begin(), chunks.end());
    for (size_t c = 0; c + 1 < chunks.size(); ++c) EXPECT_FALSE(decoder.AddChunk(chunks[c]));
    const std::optional<Frame> frame = decoder.AddChunk(chunks.back());
    ASSERT_TRUE(frame);
    ExpectWithinBounds(*frame, x, v, rho);
  }
}

TEST(FrameCodecTest, LateJoinerWaitsForAKeyframe) {
  SyntheticFrames source(500);
  std::vector<float> x, v, rho;
  FrameEncoder encoder(StreamConfig{});
  FrameDecoder early;
  for (int f = 0; f < 3; ++f) {
    source.Make(f, x, v, rho);
    early.AddChunks(encoder.Encode(Input(x, v, rho, f, f / 60.0)));
  }
  FrameDecoder late;
  source.Make(3, x, v, rho);
  EXPECT_FALSE(late.AddChunks(encoder.Encode(Input(x, v, rho, 3, 0.05))));
  EXPECT_TRUE(late.waiting_for_keyframe());
  encoder.RequestKeyframe();  // what the server does when a subscriber joins
  source.Make(4, x, v, rho);
  const std::optional<Frame> frame = late.AddChunks(encoder.Encode(Input(x, v, rho, 4, 0.06)));
  ASSERT_TRUE(frame);
  EXPECT_TRUE(frame->keyframe);
  ExpectWithinBounds(*frame, x, v, rho);
}

TEST(FrameCodecTest, AMissedFrameStopsDeltasUntilTheNextKeyframe) {
  SyntheticFrames source(500);
  std::vector<float> x, v, rho;
  FrameEncoder encoder(StreamConfig{});
  FrameDecoder decoder;
  for (int f = 0; f < 4; ++f) {
    source.Make(f, x, v, rho);
    std::vector<Chunk> chunks = encoder.Encode(Input(x, v, rho, f, f / 60.0));
    if (f == 1) continue;  // dropped on the way
    const std::optional<Frame> frame = decoder.AddChunks(chunks);
    EXPECT_EQ(frame.has_value(), f == 0) << "frame " << f;
  }
}

TEST(FrameCodecTest, EmptyFrame) {
  FrameEncoder encoder(StreamConfig{});
  FrameDecoder decoder;
  const std::vector<float> none;
  const std::vector<Chunk> chunks = encoder.Encode(Input(none, none, none, 0, 0));
  ASSERT_EQ(chunks.size(), 1u);
  const Frame frame = DecodeAll(decoder, chunks);
  EXPECT_EQ(frame.count, 0u);
}

TEST(FrameCodecTest, EmptyFrameWithEveryField) {
  StreamConfig config;
  config.fields = kAllFields;
  FrameEncoder encoder(config);
  FrameDecoder decoder;
  const std::vector<float> none;
  EXPECT_EQ(DecodeAll(decoder, encoder.Encode(Input(none, none, none, 0, 0))).count, 0u);
}

TEST(FrameCodecTest, EncodingIsIdenticalWithOneAndTwoThreads) {
  SyntheticFrames source(3000);
  std::vector<float> x, v, rho;
  StreamConfig config;
  config.fields = kAllFields;
  config.chunk_particles = 1000;
  auto encode = [&](int threads) {
    omp_set_num_threads(threads);
    FrameEncoder encoder(config);
    std::vector<Chunk> all;
    for (int f = 0; f < 3; ++f) {
      source.Make(f, x, v, rho);
      for (Chunk& c : encoder.Encode(Input(x, v, rho, f, f / 60.0))) all.push_back(std::move(c));
    }
    return all;
  };
  const auto one = encode(1);
  const auto two = encode(2);
  omp_set_num_threads(2);
  EXPECT_EQ(one, two);
}

TEST(FrameCodecTest, LargestChunksStayUnderTheGrpcMessageLimit) {
  // The worst case the format allows in a chunk: 2^16 particles, every field at full width,
  // incompressible values (random positions, keyframe).
  SyntheticFrames source(1u << 16, 99);
  std::vector<float> x, v, rho;
  source.Make(0, x, v, rho);
  uint64_t s = 5;
  for (float& c : x) {
    s = s * 6364136223846793005ull + 1;
    c = float(-5 + 10 * double(s >> 11) * 0x1.0p-53);
  }
  StreamConfig config;
  config.fields = kAllFields;
  config.position_bits = 24;
  config.speed_bits = config.velocity_bits = config.density_bits = 16;
  FrameEncoder encoder(config);
  for (const Chunk& c : encoder.Encode(Input(x, v, rho, 0, 0))) {
    EXPECT_LT(c.size(), size_t(4) << 20);
  }
}

TEST(StreamConfigTest, InvalidValuesNameTheField) {
  auto message = [](StreamConfig c) {
    try {
      c.Validate();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  StreamConfig c;
  c.position_bits = 30;
  EXPECT_THAT(message(c), HasSubstr("position_bits: allowed range [1, 24]"));
  c = {};
  c.fields = kSpeed;
  EXPECT_THAT(message(c), HasSubstr("fields"));
  c = {};
  c.stride = 0;
  EXPECT_THAT(message(c), HasSubstr("stride"));
  c = {};
  c.keyframe_interval = 0;
  EXPECT_THAT(message(c), HasSubstr("keyframe_interval"));
}

// ---------------------------------------------------------------------------------------------
// Bad input: clear errors, never a crash.

std::string DecodeErrorOf(FrameDecoder& decoder, const Chunk& chunk) {
  try {
    decoder.AddChunk(chunk);
  } catch (const DecodeError& e) {
    return e.what();
  }
  return "no error";
}

Chunk OneKeyframeChunk() {
  SyntheticFrames source(2000);
  std::vector<float> x, v, rho;
  source.Make(0, x, v, rho);
  StreamConfig config;
  config.fields = kAllFields;
  FrameEncoder encoder(config);
  return encoder.Encode(Input(x, v, rho, 0, 0)).at(0);
}

TEST(FrameDecoderTest, TruncatedHeaderAndPayload) {
  const Chunk chunk = OneKeyframeChunk();
  FrameDecoder decoder;
  EXPECT_THAT(DecodeErrorOf(decoder, Chunk(chunk.begin(), chunk.begin() + 20)),
              HasSubstr("truncated"));
  EXPECT_THAT(DecodeErrorOf(decoder, Chunk(chunk.begin(), chunk.end() - 1)),
              HasSubstr("truncated"));
}

TEST(FrameDecoderTest, BadMagicAndNewerVersion) {
  Chunk chunk = OneKeyframeChunk();
  FrameDecoder decoder;
  Chunk bad = chunk;
  bad[0] ^= 0xFF;
  EXPECT_THAT(DecodeErrorOf(decoder, bad), HasSubstr("magic"));
  Chunk newer = chunk;
  newer[4] = uint8_t(kVersion + 1);
  EXPECT_THAT(DecodeErrorOf(decoder, newer),
              HasSubstr("version " + std::to_string(kVersion + 1) + " is newer than this decoder"));
}

TEST(FrameDecoderTest, CorruptPayloadIsAnErrorAndTheDecoderRecovers) {
  const Chunk chunk = OneKeyframeChunk();
  FrameDecoder decoder;
  Chunk corrupt = chunk;
  for (size_t i = kHeaderSize + 10; i < corrupt.size(); i += 7) corrupt[i] ^= 0x5A;
  EXPECT_THAT(DecodeErrorOf(decoder, corrupt), HasSubstr("corrupt"));
  EXPECT_TRUE(decoder.AddChunk(chunk).has_value());  // a good keyframe decodes again
}

TEST(FrameDecoderTest, HostileHeaderValuesAreRejected) {
  const Chunk chunk = OneKeyframeChunk();
  auto with = [&](size_t offset, auto value) {
    Chunk c = chunk;
    std::memcpy(c.data() + offset, &value, sizeof(value));
    return c;
  };
  FrameDecoder decoder;
  EXPECT_THAT(DecodeErrorOf(decoder, with(12, uint32_t{0xFFFFFFFF})), HasSubstr("count"));
  EXPECT_THAT(DecodeErrorOf(decoder, with(12, uint32_t{1u << 26})), HasSubstr("over the limit"));
  EXPECT_THAT(DecodeErrorOf(decoder, with(48, uint8_t{40})), HasSubstr("bit width"));
  EXPECT_THAT(DecodeErrorOf(decoder, with(52, uint32_t{0})), HasSubstr("stride"));
  EXPECT_THAT(DecodeErrorOf(decoder, with(56, std::nan(""))), HasSubstr("range"));
  // Finite bounds whose difference is not: the step would be infinite and values NaN.
  Chunk wide = with(56, -1e308);
  const double huge = 1e308;
  std::memcpy(wide.data() + 80, &huge, sizeof(huge));
  EXPECT_THAT(DecodeErrorOf(decoder, wide), HasSubstr("range"));
  EXPECT_THAT(DecodeErrorOf(decoder, with(136, uint32_t{1u << 30})), HasSubstr("corrupt"));
  EXPECT_THAT(DecodeErrorOf(decoder, with(34, uint16_t{0})), HasSubstr("chunk index"));
}

TEST(FrameDecoderTest, DuplicateChunkIsRejected) {
  SyntheticFrames source(1000);
  std::vector<float> x, v, rho;
  source.Make(0, x, v, rho);
  StreamConfig config;
  config.chunk_particles = 400;
  FrameEncoder encoder(config);
  const std::vector<Chunk> chunks = encoder.Encode(Input(x, v, rho, 0, 0));
  FrameDecoder decoder;
  EXPECT_FALSE(decoder.AddChunk(chunks[0]));
  EXPECT_THAT(DecodeErrorOf(decoder, chunks[0]), HasSubstr("received twice"));
}

TEST(FrameDecoderTest, ARejectedGroupLeavesNoChunkMarkedAsReceived) {
  SyntheticFrames source(1000);
  std::vector<float> x, v, rho;
  source.Make(0, x, v, rho);
  StreamConfig config;
  config.chunk_particles = 400;
  FrameEncoder encoder(config);
  const std::vector<Chunk> chunks = encoder.Encode(Input(x, v, rho, 0, 0));
  ASSERT_EQ(chunks.size(), 3u);
  FrameDecoder decoder;
  const std::vector<Chunk> bad = {chunks[0], chunks[1], chunks[1]};
  EXPECT_THROW(decoder.AddChunks(bad), DecodeError);
  // Chunks 0 and 1 were not decoded: the frame is complete only once they come again.
  EXPECT_FALSE(decoder.AddChunk(chunks[2]));
  EXPECT_FALSE(decoder.AddChunk(chunks[0]));
  const std::optional<Frame> frame = decoder.AddChunk(chunks[1]);
  ASSERT_TRUE(frame);
  ExpectWithinBounds(*frame, x, v, rho);
}

TEST(FrameDecoderTest, ChunksMustCoverTheFrameExactlyOnce) {
  SyntheticFrames source(1000);
  std::vector<float> x, v, rho;
  source.Make(0, x, v, rho);
  StreamConfig config;
  config.chunk_particles = 400;
  FrameEncoder encoder(config);
  const std::vector<Chunk> chunks = encoder.Encode(Input(x, v, rho, 0, 0));
  // Chunk 1 claiming to start at particle 300 would overlap chunk 0 and leave 700-799 undecoded.
  Chunk shifted = chunks[1];
  const uint32_t first = 300;
  std::memcpy(shifted.data() + 36, &first, sizeof(first));
  FrameDecoder decoder;
  EXPECT_FALSE(decoder.AddChunk(chunks[0]));
  EXPECT_THAT(DecodeErrorOf(decoder, shifted), HasSubstr("does not fit the frame's other chunks"));
}

TEST(FrameCodecTest, OctahedralFramesAreVersion2AndOthersStayVersion1) {
  SyntheticFrames source(500);
  std::vector<float> x, v, rho;
  source.Make(0, x, v, rho);
  StreamConfig config;
  config.fields = kPositions | kVelocity;
  const Chunk components = FrameEncoder(config).Encode(Input(x, v, rho, 0, 0)).at(0);
  config.velocity_encoding = VelocityEncoding::kOctahedral;
  const Chunk octahedral = FrameEncoder(config).Encode(Input(x, v, rho, 0, 0)).at(0);
  EXPECT_EQ(components[4], 1);  // older decoders keep reading streams without the new encoding
  EXPECT_EQ(octahedral[4], 2);
  EXPECT_EQ(octahedral[6] & 2, 2);
  // The octahedral flag in a version 1 header is unknown there.
  Chunk mislabelled = octahedral;
  mislabelled[4] = 1;
  FrameDecoder decoder;
  EXPECT_THAT(DecodeErrorOf(decoder, mislabelled), HasSubstr("unknown flags 3 for version 1"));
}

}  // namespace
}  // namespace dysa::codec
