// The level of detail by rank (detail_subset.h): stable, nested and spatially even subsets, and
// frames of such a subset through the codec (ids, delta coding, hostile headers).
#include "dysa/codec/detail_subset.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <random>
#include <set>
#include <vector>

#include "codec/frame_codec_test_util.h"
#include "dysa/codec/frame_codec.h"

namespace dysa::codec {
namespace {

TEST(DetailSubset, SplitMix64MatchesTheReferenceSequence) {
  // splitmix64 seeded with 0: its first outputs are SplitMix64(0), SplitMix64(gamma), ...
  EXPECT_EQ(SplitMix64(0), 0xE220A8397B1DCDAFull);
  EXPECT_EQ(SplitMix64(0x9E3779B97F4A7C15ull), 0x6E789E6AA1B965F4ull);
}

TEST(DetailSubset, ThresholdsMapFractions) {
  EXPECT_EQ(DetailThreshold(1.0), 0u);
  EXPECT_EQ(DetailThreshold(2.0), 0u);
  EXPECT_EQ(DetailThreshold(0.5), 0x80000000u);
  EXPECT_GE(DetailThreshold(1e-12), 1u);
  EXPECT_DOUBLE_EQ(DetailFraction(0), 1.0);
  EXPECT_DOUBLE_EQ(DetailFraction(0x40000000u), 0.25);
  EXPECT_THROW(DetailThreshold(0.0), std::invalid_argument);
  EXPECT_THROW(DetailThreshold(-0.1), std::invalid_argument);
  EXPECT_THROW(DetailThreshold(NAN), std::invalid_argument);
}

TEST(DetailSubset, KeepsTheFractionAskedFor) {
  const size_t n = 200000;
  for (double f : {0.01, 0.1, 0.37, 0.9}) {
    const double kept = double(KeptIds(n, 1, DetailThreshold(f)).size());
    const double sigma = std::sqrt(n * f * (1 - f));
    EXPECT_NEAR(kept, n * f, 5 * sigma) << f;
  }
  EXPECT_EQ(KeptIds(n, 1, 0).size(), n);
  EXPECT_EQ(KeptIds(n, 4, 0).size(), n / 4);
}

TEST(DetailSubset, IsStableAndNested) {
  const size_t n = 50000;
  std::vector<uint32_t> previous;
  for (double f = 0.02; f <= 1.0; f *= 1.5) {
    const std::vector<uint32_t> ids = KeptIds(n, 1, DetailThreshold(f));
    // Stable: the same call gives the same ids (no state, no randomness per frame).
    EXPECT_EQ(ids, KeptIds(n, 1, DetailThreshold(f)));
    // Nested: every particle of the smaller subset is in the larger one.
    EXPECT_TRUE(std::includes(ids.begin(), ids.end(), previous.begin(), previous.end())) << f;
    EXPECT_GT(ids.size(), previous.size());
    previous = ids;
  }
  // More particles (a larger scene) keep the ids they had.
  const std::vector<uint32_t> small = KeptIds(1000, 1, DetailThreshold(0.3));
  const std::vector<uint32_t> large = KeptIds(2000, 1, DetailThreshold(0.3));
  EXPECT_TRUE(std::equal(small.begin(), small.end(), large.begin()));
}

TEST(DetailSubset, DecoderSideFindsTheSameIds) {
  const uint32_t t = DetailThreshold(0.2);
  const std::vector<uint32_t> ids = KeptIds(30000, 3, t);
  std::vector<uint32_t> found;
  ASSERT_TRUE(FirstKeptIds(uint32_t(ids.size()), 3, t, 20'000'000, found));
  EXPECT_EQ(found, ids);
  EXPECT_FALSE(FirstKeptIds(1000, 1, 1, 100000, found));  // 1 / 2^32 keeps ~nothing
}

// Chi-square of the kept particles' counts per cell of a cells^3 grid over [0, 1)^3 against the
// binomial expectation (each of a cell's particles kept with probability f), per cell.
double ChiSquarePerCell(const std::vector<float>& positions, const std::vector<uint32_t>& kept,
                        double f, int cells) {
  std::vector<double> total(size_t(cells * cells * cells)), got(total.size());
  auto cell = [&](uint32_t id) {
    int c[3];
    for (int a = 0; a < 3; ++a) c[a] = std::min(cells - 1, int(positions[3 * id + a] * cells));
    return size_t((c[0] * cells + c[1]) * cells + c[2]);
  };
  for (uint32_t id = 0; id < positions.size() / 3; ++id) total[cell(id)] += 1;
  for (uint32_t id : kept) got[cell(id)] += 1;
  double chi2 = 0;
  for (size_t c = 0; c < total.size(); ++c) {
    const double expected = total[c] * f, variance = total[c] * f * (1 - f);
    chi2 += (got[c] - expected) * (got[c] - expected) / variance;
  }
  return chi2 / double(total.size());
}

// A lattice of 40^3 particles in [0, 1)^3 with ids in lattice order (as a block spawns them).
std::vector<float> Lattice() {
  const int side = 40;
  std::vector<float> p;
  for (int i = 0; i < side; ++i)
    for (int j = 0; j < side; ++j)
      for (int k = 0; k < side; ++k)
        for (int v : {i, j, k}) p.push_back((v + 0.5f) / side);
  return p;
}

TEST(DetailSubset, IsSpatiallyEvenWhereStridingClusters) {
  // Ids sorted by position: every 8th id keeps every 8th plane (three of eight columns of
  // cells are empty); the rank keeps an even sample, its counts binomial (chi2 / cell ~ 1).
  const std::vector<float> lattice = Lattice();
  const size_t n = lattice.size() / 3;
  const double f = 1.0 / 8;
  const double rank = ChiSquarePerCell(lattice, KeptIds(n, 1, DetailThreshold(f)), f, 8);
  const double stride = ChiSquarePerCell(lattice, KeptIds(n, 8, 0), f, 8);
  EXPECT_LT(rank, 1.4);
  EXPECT_GT(rank, 0.6);
  EXPECT_GT(stride, 10.0);
}

TEST(DetailSubset, StaysEvenWhenTheFluidMixes) {
  // A mixed fluid: the lattice's positions shuffled among the ids. The rank does not depend on
  // position, so the counts stay binomial at every fraction.
  std::vector<float> lattice = Lattice();
  const size_t n = lattice.size() / 3;
  std::vector<uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::mt19937 rng(7);
  std::shuffle(order.begin(), order.end(), rng);
  std::vector<float> mixed(lattice.size());
  for (size_t i = 0; i < n; ++i) std::copy_n(&lattice[3 * size_t(order[i])], 3, &mixed[3 * i]);
  for (double f : {0.05, 0.25, 0.6}) {
    const double chi2 = ChiSquarePerCell(mixed, KeptIds(n, 1, DetailThreshold(f)), f, 8);
    EXPECT_LT(chi2, 1.4) << f;
    EXPECT_GT(chi2, 0.6) << f;
  }
}

TEST(DetailSubset, FramesCarryTheirIdsAndDeltaCodingStillPays) {
  testing::SyntheticFrames frames(20000);
  StreamConfig config;
  config.fields = kPositions | kSpeed;
  config.detail_threshold = DetailThreshold(0.25);
  config.chunk_particles = 1500;  // several chunks
  FrameEncoder encoder(config);
  FrameDecoder decoder;
  const std::vector<uint32_t> expected_ids = KeptIds(20000, 1, config.detail_threshold);
  std::vector<float> p, v, d;
  size_t key_bytes = 0, delta_bytes = 0;
  for (int f = 0; f < 4; ++f) {
    frames.Make(f, p, v, d);
    const auto chunks = encoder.Encode(testing::Input(p, v, d, f, f / 60.0));
    size_t bytes = 0;
    for (const Chunk& c : chunks) bytes += c.size();
    (f == 0 ? key_bytes : delta_bytes) = bytes;
    EXPECT_EQ(chunks[0][4], 3) << "format version 3 with a detail threshold";
    const auto frame = decoder.AddChunks(chunks);
    ASSERT_TRUE(frame.has_value()) << f;
    EXPECT_EQ(frame->keyframe, f == 0);
    EXPECT_EQ(frame->detail_threshold, config.detail_threshold);
    ASSERT_EQ(frame->ids, expected_ids);
    EXPECT_EQ(ParticleIds(*frame), expected_ids);
    for (size_t k = 0; k < frame->count; k += 97) {
      for (int a = 0; a < 3; ++a) {
        EXPECT_NEAR(frame->positions[3 * k + a], p[3 * size_t(frame->ids[k]) + a],
                    frame->position_error[a] + 1e-6);
      }
    }
  }
  EXPECT_LT(delta_bytes, key_bytes);
}

TEST(DetailSubset, StreamsWithoutAThresholdStayVersionOne) {
  testing::SyntheticFrames frames(1000);
  std::vector<float> p, v, d;
  frames.Make(0, p, v, d);
  StreamConfig config;
  config.stride = 3;
  FrameEncoder encoder(config);
  const auto chunks = encoder.Encode(testing::Input(p, v, d, 0, 0));
  EXPECT_EQ(chunks[0][4], 1);
  FrameDecoder decoder;
  const auto frame = decoder.AddChunks(chunks);
  ASSERT_TRUE(frame.has_value());
  EXPECT_TRUE(frame->ids.empty());
  EXPECT_EQ(ParticleIds(*frame)[5], 15u);
}

TEST(DetailSubset, RejectsACountTheThresholdCannotSelect) {
  testing::SyntheticFrames frames(1000);
  std::vector<float> p, v, d;
  frames.Make(0, p, v, d);
  StreamConfig config;
  config.detail_threshold = DetailThreshold(0.5);
  FrameEncoder encoder(config);
  auto chunks = encoder.Encode(testing::Input(p, v, d, 0, 0));
  ASSERT_EQ(chunks.size(), 1u);
  // A hostile header: a threshold of 1 (keeps ~nothing of 20 million ids) for ~500 particles.
  const uint32_t one = 1;
  std::memcpy(chunks[0].data() + 148, &one, 4);
  FrameDecoder decoder;
  EXPECT_THROW(decoder.AddChunks(chunks), DecodeError);
  // The threshold in a version 1 header is the reserved field: refused as before.
  chunks = encoder.Encode(testing::Input(p, v, d, 1, 0));
  chunks[0][4] = 1;
  EXPECT_THROW(FrameDecoder().AddChunks(chunks), DecodeError);
}

}  // namespace
}  // namespace dysa::codec
