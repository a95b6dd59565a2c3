// ctest -L mpi, run by mpirun on 2 and 3 ranks (mpi_test_main.h): MpiCommunicator moves messages of
// any size. MPI's counts are int, so messages past 2 GiB go in rounds; these tests make the rounds
// a few bytes long, so that small messages take many rounds (uneven sizes, empty messages, a
// process that sends nothing while another sends many rounds), and check every byte that arrives. A
// decomposed simulation on such a communicator reaches the checkpoint it reaches on the default
// one, bit for bit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <vector>

#include "dysa/core/scene.h"
#include "dysa/distributed/distributed_simulation.h"
#include "mpi_test_main.h"

#ifndef DYSA_RANKS_SCENE
#error "tests/CMakeLists.txt defines DYSA_RANKS_SCENE"
#endif

namespace dysa::distributed {
namespace {

// A message's bytes from process `from` to process `to`: a length that differs for every pair
// (0 for some) and content that names the pair and the position.
Bytes MessageOf(int from, int to, size_t scale) {
  const size_t length = (size_t(3 * from + 5 * to) % 7) * scale + size_t(from == to);
  Bytes bytes(length);
  for (size_t k = 0; k < length; ++k) bytes[k] = std::byte((31 * from + 17 * to + k) & 0xff);
  return bytes;
}

class MpiCommunicatorTest : public ::testing::TestWithParam<size_t> {};

TEST_P(MpiCommunicatorTest, AllToAllDeliversEveryByteInRounds) {
  const MpiCommunicator comm({.round_bytes = GetParam()});
  std::vector<Bytes> to(size_t(comm.size()));
  for (int p = 0; p < comm.size(); ++p) to[size_t(p)] = MessageOf(comm.rank(), p, 11);
  const std::vector<Bytes> from = comm.AllToAll(to);
  ASSERT_EQ(from.size(), size_t(comm.size()));
  for (int p = 0; p < comm.size(); ++p) EXPECT_EQ(from[size_t(p)], MessageOf(p, comm.rank(), 11));
}

TEST_P(MpiCommunicatorTest, GatherToRootDeliversEveryByteInRounds) {
  const MpiCommunicator comm({.round_bytes = GetParam()});
  // Rank 1 sends nothing: the others' rounds go on without it.
  const Bytes mine = comm.rank() == 1 ? Bytes{} : MessageOf(comm.rank(), 0, 13);
  const std::vector<Bytes> from = comm.GatherToRoot(mine);
  if (comm.rank() != 0) {
    EXPECT_TRUE(from.empty());
    return;
  }
  ASSERT_EQ(from.size(), size_t(comm.size()));
  for (int p = 0; p < comm.size(); ++p) {
    EXPECT_EQ(from[size_t(p)], p == 1 ? Bytes{} : MessageOf(p, 0, 13)) << "from rank " << p;
  }
}

TEST_P(MpiCommunicatorTest, BroadcastDeliversEveryByteInRounds) {
  const MpiCommunicator comm({.round_bytes = GetParam()});
  const size_t round = std::min<size_t>(GetParam(), 64);
  for (size_t length : {size_t(0), size_t(1), round, 3 * round + 2}) {
    Bytes expected(length);
    for (size_t k = 0; k < length; ++k) expected[k] = std::byte((7 * k + 3) & 0xff);
    Bytes bytes = comm.rank() == 0 ? expected : Bytes{};
    comm.Broadcast(bytes);
    EXPECT_EQ(bytes, expected) << length << " bytes";
  }
}

INSTANTIATE_TEST_SUITE_P(RoundBytes, MpiCommunicatorTest,
                         ::testing::Values(1, 4, 64, size_t(1) << 30));

TEST(MpiCommunicatorRoundsTest, ARoundFitsIntOffsetsForEveryProcess) {
  const MpiCommunicator comm;
  EXPECT_EQ(comm.round_bytes(),
            std::min(MpiCommunicator::kDefaultRoundBytes,
                     size_t(std::numeric_limits<int>::max()) / size_t(comm.size())));
  EXPECT_THROW(MpiCommunicator({.round_bytes = 0}), std::invalid_argument);
  EXPECT_THROW(MpiCommunicator({.wait_limit_s = 0}), std::invalid_argument);
}

TEST(MpiCommunicatorRoundsTest, ASimulationOnShortRoundsReachesTheSameCheckpoint) {
  // Every exchange, gather and broadcast of the decomposition in rounds of 5 bytes (a particle's
  // record is longer: records split across rounds).
  const Scene scene = LoadScene(DYSA_RANKS_SCENE);
  const MpiCommunicator whole;
  const MpiCommunicator rounds({.round_bytes = 5});
  DistributedSimulation a(scene, whole);
  DistributedSimulation b(scene, rounds);
  for (int k = 0; k < 12; ++k) {
    a.Step(a.time() + 1e-3);
    b.Step(b.time() + 1e-3);
  }
  EXPECT_GT(b.totals().migrated + b.totals().ghosts, 0u);
  EXPECT_GT(b.totals().bytes_sent, 100 * rounds.round_bytes());  // many rounds a step
  const Checkpoint ca = a.SaveCheckpoint();
  const Checkpoint cb = b.SaveCheckpoint();
  const uint64_t ha = a.GlobalStateHash();
  const uint64_t hb = b.GlobalStateHash();
  if (whole.rank() == 0) {
    EXPECT_EQ(ha, hb);
    EXPECT_EQ(cb.step, ca.step);
    EXPECT_EQ(cb.id, ca.id);
    EXPECT_TRUE(cb.position == ca.position);
    EXPECT_TRUE(cb.velocity == ca.velocity);
  }
}

}  // namespace
}  // namespace dysa::distributed
