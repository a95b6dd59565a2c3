// Frames of an explicit subset (StreamConfig::explicit_ids, format version 4): the ids travel in
// keyframes, delta frames reuse them, a new subset is a keyframe, and subsets of one frame decode
// to the full frame's positions bit-exactly.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "codec/frame_codec_test_util.h"
#include "dysa/codec/frame_codec.h"

namespace dysa::codec {
namespace {

// Every id whose (id * 7) % 10 is below `tenths`: an uneven pattern with runs and gaps.
std::vector<uint32_t> Subset(uint32_t n, uint32_t tenths, uint32_t shift = 0) {
  std::vector<uint32_t> ids;
  for (uint32_t i = 0; i < n; ++i) {
    if ((i * 7 + shift) % 10 < tenths) ids.push_back(i);
  }
  return ids;
}

size_t Bytes(const std::vector<Chunk>& chunks) {
  size_t bytes = 0;
  for (const Chunk& c : chunks) bytes += c.size();
  return bytes;
}

TEST(ExplicitIds, IdsTravelInKeyframesAndDeltaFramesReuseThem) {
  testing::SyntheticFrames frames(20000);
  StreamConfig config;
  config.fields = kPositions | kSpeed | kVelocity | kDensity;
  config.explicit_ids = true;
  config.chunk_particles = 1700;  // several chunks
  FrameEncoder encoder(config);
  FrameDecoder decoder;
  std::vector<float> p, v, d;
  std::vector<uint32_t> ids = Subset(20000, 3);
  size_t key_bytes = 0, delta_bytes = 0;
  for (int f = 0; f < 5; ++f) {
    if (f == 3) ids = Subset(20000, 4, 1);  // the subset changes: a keyframe with the new ids
    frames.Make(f, p, v, d);
    FrameInput in = testing::Input(p, v, d, f, f / 60.0);
    in.ids = ids;
    const auto chunks = encoder.Encode(in);
    EXPECT_EQ(chunks[0][4], 4) << "format version 4 with explicit ids";
    EXPECT_GT(chunks.size(), 1u);
    if (f == 0) key_bytes = Bytes(chunks);
    if (f == 2) delta_bytes = Bytes(chunks);
    const auto frame = decoder.AddChunks(chunks);
    ASSERT_TRUE(frame.has_value()) << f;
    EXPECT_EQ(frame->keyframe, f == 0 || f == 3) << f;
    EXPECT_TRUE(frame->explicit_ids);
    ASSERT_EQ(frame->ids, ids) << f;
    EXPECT_EQ(ParticleIds(*frame), ids);
    for (size_t k = 0; k < frame->count; k += 89) {
      const size_t id = frame->ids[k];
      for (int a = 0; a < 3; ++a) {
        EXPECT_NEAR(frame->positions[3 * k + a], p[3 * id + a], frame->position_error[a] + 1e-6);
      }
      EXPECT_NEAR(frame->densities[k], d[id], frame->density_error + 1e-3);
    }
  }
  // Delta frames carry no ids and still predict from the previous frames.
  EXPECT_LT(delta_bytes, key_bytes / 2);
}

TEST(ExplicitIds, SubsetsOfOneFrameDecodeToTheFullFramesPositionsBitExactly) {
  testing::SyntheticFrames frames(5000);
  std::vector<float> p, v, d;
  frames.Make(2, p, v, d);
  p[3 * 17] = 9.0f;  // outside the domain: the range gets a margin from the whole frame's extremes
  StreamConfig full_config;
  FrameDecoder full_decoder;
  const auto full =
      full_decoder.AddChunks(FrameEncoder(full_config).Encode(testing::Input(p, v, d, 2, 0.1)));
  ASSERT_TRUE(full.has_value());

  // Two disjoint subsets (neither holds particle 17 alone) through one stream, as the server
  // sends a view subset and then the rest of the frame.
  StreamConfig config;
  config.explicit_ids = true;
  config.chunk_particles = 999;
  FrameEncoder encoder(config);
  FrameDecoder decoder;
  std::map<uint32_t, std::array<float, 3>> assembled;
  const std::vector<uint32_t> first = Subset(5000, 2);
  std::vector<uint32_t> rest;
  for (uint32_t i = 0; i < 5000; ++i) {
    if (!std::binary_search(first.begin(), first.end(), i)) rest.push_back(i);
  }
  const std::vector<uint32_t>* parts[] = {&first, &rest};
  for (const std::vector<uint32_t>* ids : parts) {
    FrameInput in = testing::Input(p, v, d, 2, 0.1);
    in.ids = *ids;
    const auto frame = decoder.AddChunks(encoder.Encode(in));
    ASSERT_TRUE(frame.has_value());
    EXPECT_TRUE(frame->keyframe);
    for (size_t k = 0; k < frame->count; ++k) {
      assembled[frame->ids[k]] = {frame->positions[3 * k], frame->positions[3 * k + 1],
                                  frame->positions[3 * k + 2]};
    }
  }
  ASSERT_EQ(assembled.size(), 5000u);
  for (const auto& [id, pos] : assembled) {
    ASSERT_EQ(std::memcmp(pos.data(), &full->positions[3 * size_t(id)], sizeof pos), 0) << id;
  }
}

TEST(ExplicitIds, BadIdsAreRefusedNamingTheField) {
  testing::SyntheticFrames frames(100);
  std::vector<float> p, v, d;
  frames.Make(0, p, v, d);
  StreamConfig config;
  config.explicit_ids = true;
  FrameEncoder encoder(config);
  for (const std::vector<uint32_t>& bad :
       {std::vector<uint32_t>{3, 3}, std::vector<uint32_t>{5, 2}, std::vector<uint32_t>{100}}) {
    FrameInput in = testing::Input(p, v, d, 0, 0);
    in.ids = bad;
    try {
      encoder.Encode(in);
      ADD_FAILURE() << "accepted bad ids";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("ids: strictly increasing, each in [0, 100)"),
                std::string::npos)
          << e.what();
    }
  }
}

TEST(ExplicitIds, HostileIdsAreDecodeErrors) {
  testing::SyntheticFrames frames(300);
  std::vector<float> p, v, d;
  frames.Make(0, p, v, d);
  StreamConfig config;
  config.explicit_ids = true;
  FrameEncoder encoder(config);
  FrameInput in = testing::Input(p, v, d, 0, 0);
  const std::vector<uint32_t> ids = Subset(300, 5);
  in.ids = ids;
  const auto chunks = encoder.Encode(in);
  ASSERT_EQ(chunks.size(), 1u);
  // The ids flag in a version 3 header is an unknown flag.
  auto old = chunks;
  old[0][4] = 3;
  EXPECT_THROW(FrameDecoder().AddChunks(old), DecodeError);
  // A delta frame whose reference had no ids (the flag differs) waits for a keyframe.
  FrameDecoder decoder;
  ASSERT_TRUE(decoder.AddChunks(chunks).has_value());
  in.ids = {};
  EXPECT_TRUE(decoder.AddChunks(encoder.Encode(in)).has_value()) << "an empty subset decodes";
}

}  // namespace
}  // namespace dysa::codec
