// Tests of clients/cli/run_distributed.h on one process (SingleProcess): it steps to the same
// times as `dysa run` and prints the same state hash; what it cannot do yet it refuses by flag.
// On MPI ranks: tests/distributed/mpi_ranks_test.sh (ctest -L mpi).
#include "run_distributed.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sstream>
#include <stdexcept>
#include <string>

#include "run_command.h"
#include "support/temp_dir.h"

#ifndef DYSA_RANKS_SCENE
#error "tests/CMakeLists.txt defines DYSA_RANKS_SCENE (tests/distributed/ranks_dam_break.json)"
#endif

namespace dysa {
namespace {

using ::testing::HasSubstr;

std::string HashLine(const std::string& text) {
  const size_t at = text.find("state hash: ");
  if (at == std::string::npos) return "";
  return text.substr(at, text.find('\n', at) - at);
}

TEST(RunDistributedTest, PrintsTheHashOfThePlainRun) {
  const dysa::testing::TempDir dir("dysa_run_distributed");
  RunOptions options;
  options.scene = DYSA_RANKS_SCENE;
  options.steps = 40;
  options.threads = 1;
  options.print_hash = true;
  options.out_dir = (dir.path() / "out").string();
  std::ostringstream plain, spread, progress;
  RunOffline(options, plain, progress);
  RunDistributed(options, distributed::SingleProcess{}, spread);
  ASSERT_THAT(HashLine(plain.str()), HasSubstr("0x"));
  EXPECT_EQ(HashLine(spread.str()), HashLine(plain.str())) << spread.str();
  EXPECT_THAT(spread.str(), HasSubstr("40 steps of 3200 particles"));
  EXPECT_THAT(spread.str(), HasSubstr("particles per rank: 3200\n"));
  EXPECT_THAT(spread.str(), HasSubstr("exchange"));
}

TEST(RunDistributedTest, RefusesFramesAndGpusByFlag) {
  RunOptions options;
  options.scene = DYSA_RANKS_SCENE;
  options.steps = 1;
  options.vtk_every = 1;
  std::ostringstream out;
  try {
    RunDistributed(options, distributed::SingleProcess{}, out);
    FAIL() << "--vtk-every accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("--vtk-every"));
  }
  options.vtk_every = 0;
  options.device = ParseDevice("cuda:0");
  try {
    RunDistributed(options, distributed::SingleProcess{}, out);
    FAIL() << "--device cuda accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("--device"));
  }
}

}  // namespace
}  // namespace dysa
