// Tests of clients/cli/run_distributed.h on one process (SingleProcess): it steps to the same
// times as `dysa run` and writes the same hash, probes.csv and VTK frames, byte for byte; a GPU
// that cannot run it refuses by flag, and GPU ranks take every solver CPU ranks take (GPU ranks
// stepping: distributed_gpu_test, mpi_gpu_ranks_test).
// On MPI ranks: tests/distributed/mpi_ranks_test.sh (ctest -L mpi).
#include "run_distributed.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>

#include "dysa/core/device.h"
#include "dysa/core/types.h"
#include "run_command.h"
#include "support/temp_dir.h"

#if !defined(DYSA_RANKS_SCENE) || !defined(DYSA_RANKS_SEED_SCENE) || \
    !defined(DYSA_RANKS_DFSPH_SCENE)
#error "tests/CMakeLists.txt defines DYSA_RANKS_SCENE, _SEED_SCENE and _DFSPH_SCENE"
#endif

namespace dysa {
namespace {

using ::testing::HasSubstr;

std::string HashLine(const std::string& text) {
  const size_t at = text.find("state hash: ");
  if (at == std::string::npos) return "";
  return text.substr(at, text.find('\n', at) - at);
}

RunOptions SmallRun(const std::filesystem::path& out, const char* scene, uint64_t steps) {
  RunOptions options;
  options.scene = scene;
  options.steps = steps;
  options.threads = 1;
  options.print_hash = true;
  options.vtk_every = 2;
  options.out_dir = out.string();
  return options;
}

// Every file of `dir` (recursively) by its path relative to `dir`.
std::map<std::string, std::string> Files(const std::filesystem::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file()) {
      files[std::filesystem::relative(entry.path(), dir).string()] =
          dysa::testing::ReadFile(entry.path());
    }
  }
  return files;
}

void ExpectSameOutput(const char* scene, uint64_t steps) {
  const dysa::testing::TempDir dir("dysa_run_distributed");
  std::ostringstream plain, spread, progress;
  RunOffline(SmallRun(dir.path() / "plain", scene, steps), plain, progress);
  RunDistributed(SmallRun(dir.path() / "spread", scene, steps), distributed::SingleProcess{},
                 spread);
  ASSERT_THAT(HashLine(plain.str()), HasSubstr("0x"));
  EXPECT_EQ(HashLine(spread.str()), HashLine(plain.str())) << spread.str();
  EXPECT_THAT(spread.str(), HasSubstr(std::to_string(steps) + " steps of "));
  EXPECT_THAT(spread.str(), HasSubstr("exchange"));
  // The exchange's own time, apart from the wait for the slowest rank (scaling_bench reads it).
  EXPECT_THAT(spread.str(), HasSubstr("exchange without waiting: "));
  EXPECT_THAT(spread.str(), HasSubstr("waiting for the slowest rank first: "));
  // probes.csv and every VTK frame, byte for byte.
  const auto expected = Files(dir.path() / "plain");
  const auto actual = Files(dir.path() / "spread");
  EXPECT_GT(expected.size(), 3u);  // probes.csv, frames.pvd and frames
  ASSERT_EQ(actual.size(), expected.size());
  for (const auto& [name, bytes] : expected) {
    ASSERT_TRUE(actual.count(name)) << name;
    EXPECT_TRUE(actual.at(name) == bytes) << name << " differs";
  }
}

TEST(RunDistributedTest, WritesTheHashProbesAndFramesOfThePlainRun) {
  ExpectSameOutput(DYSA_RANKS_SCENE, 40);
}

TEST(RunDistributedTest, TheSeedModelToo) { ExpectSameOutput(DYSA_RANKS_SEED_SCENE, 30); }

// The field a ConfigError of RunDistributed names ("" for none, or another exception).
std::string RefusedField(RunOptions options) {
  std::ostringstream out;
  try {
    RunDistributed(options, distributed::SingleProcess{}, out);
  } catch (const ConfigError& e) {
    return e.field();
  }
  return "";
}

TEST(RunDistributedTest, GpuRanksTakeDfsph) {
  if (DeviceUnavailableReason(ParseDevice("cuda:0")).empty()) {
    GTEST_SKIP() << "cuda:0 can run here: mpi_gpu_ranks_dfsph_test runs dfsph on GPU ranks";
  }
  // dfsph is not refused by its solver (it was, before its ghosts refreshed through the
  // device): without a GPU only the device is.
  const dysa::testing::TempDir dir("dysa_run_distributed");
  RunOptions options = SmallRun(dir.path() / "out", DYSA_RANKS_DFSPH_SCENE, 1);
  options.device = ParseDevice("cuda:0");
  EXPECT_EQ(RefusedField(options), "device");
}

TEST(RunDistributedTest, AGpuThatCannotRunIsRefusedByFlag) {
  if (DeviceUnavailableReason(ParseDevice("cuda:0")).empty()) {
    GTEST_SKIP() << "cuda:0 can run here: distributed_gpu_test checks GPU ranks";
  }
  const dysa::testing::TempDir dir("dysa_run_distributed");
  RunOptions options = SmallRun(dir.path() / "out", DYSA_RANKS_SCENE, 1);
  options.device = ParseDevice("cuda:0");
  EXPECT_EQ(RefusedField(options), "device");
}

TEST(RunDistributedTest, AnOutputThatCannotBeWrittenIsAnErrorOfEveryRank) {
  const dysa::testing::TempDir dir("dysa_run_distributed");
  std::ofstream(dir.path() / "file") << "not a directory";
  RunOptions options = SmallRun(dir.path() / "file" / "out", DYSA_RANKS_SCENE, 1);
  std::ostringstream out;
  EXPECT_THROW(RunDistributed(options, distributed::SingleProcess{}, out), CollectiveError);
}

}  // namespace
}  // namespace dysa
