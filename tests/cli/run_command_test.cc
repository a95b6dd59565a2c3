// Tests of clients/cli/run_command.h (`dysa run`): the files an offline run writes, its timing
// table, its errors, and the real `dysa` executable's exit codes and messages.
#include "run_command.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "dysa/core/device.h"
#include "dysa/core/params.h"
#include "dysa/core/probes.h"
#include "dysa/core/scene.h"
#include "dysa/core/types.h"
#include "support/temp_dir.h"

#if !defined(DYSA_BINARY) || !defined(DYSA_DOCS_DIR)
#error "tests/CMakeLists.txt defines DYSA_BINARY (the dysa executable) and DYSA_DOCS_DIR"
#endif

namespace dysa {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

using dysa::testing::CommandResult;
using dysa::testing::ReadFile;
using dysa::testing::RunCaptured;

// Each test gets its own directory.
struct TempDir : dysa::testing::TempDir {
  TempDir() : dysa::testing::TempDir("dysa_run") {}
};

std::vector<std::string> Split(const std::string& text, char separator) {
  std::vector<std::string> parts;
  std::string part;
  std::istringstream in(text);
  while (std::getline(in, part, separator)) parts.push_back(part);
  return parts;
}

RunOptions SmallRun(const fs::path& out_dir) {
  RunOptions options;
  options.scene = "seed_basic";
  options.sets = {"particle_quantity=8"};
  options.steps = 12;
  options.out_dir = (out_dir / "out").string();
  return options;
}

TEST(RunOfflineTest, WritesProbesCsvWithAHeaderAndARowPerFrame) {
  TempDir dir;
  const RunOptions options = SmallRun(dir.path());
  std::ostringstream out, progress;
  RunOffline(options, out, progress);

  const fs::path csv = fs::path(options.out_dir) / "probes.csv";
  ASSERT_TRUE(fs::exists(csv));
  const std::vector<std::string> lines = Split(ReadFile(csv), '\n');
  ASSERT_FALSE(lines.empty());
  std::string header = "time,step";
  const Scene scene = LoadScene("seed_basic");
  for (const std::string& column : ProbeColumns(scene.probes)) header += "," + column;
  EXPECT_EQ(lines[0], header);
  EXPECT_THAT(lines[0], HasSubstr("density_mean,density_max"));

  // 12 steps at 3 steps per frame: the t = 0 row and one per frame.
  const int ipf = scene.params.iterations_per_frame;
  ASSERT_EQ(ipf, 3);
  ASSERT_EQ(lines.size(), 1u + 1 + 12 / ipf);
  const size_t columns = Split(header, ',').size();
  const double dt = 1.0 / (60.0 * 3);
  for (size_t r = 1; r < lines.size(); ++r) {
    const std::vector<std::string> cells = Split(lines[r], ',');
    ASSERT_EQ(cells.size(), columns) << lines[r];
    const double time = std::stod(cells[0]);
    const int step = std::stoi(cells[1]);
    EXPECT_EQ(step, int(r - 1) * ipf) << lines[r];
    EXPECT_NEAR(time, step * dt, 1e-7) << lines[r];
    for (const std::string& cell : cells) {
      EXPECT_TRUE(std::isfinite(std::stod(cell))) << lines[r];
    }
    // The inside_domain probe counts all 512 particles.
    EXPECT_EQ(cells.back(), "512") << lines[r];
  }
  EXPECT_FALSE(fs::exists(fs::path(options.out_dir) / "frames.pvd"));  // no --vtk-every
}

// wcsph takes adaptive steps; each probe row still lands on an exact multiple of the interval.
TEST(RunOfflineTest, AdaptiveSolverWritesProbeRowsAtExactTimes) {
  TempDir dir;
  RunOptions options;
  options.scene = "dam_break_martin_moyce";
  options.sets = {"particle_spacing=0.0057"};  // 10 x 20 x 1 particles: quick
  options.end_time = 0.02;
  options.out_dir = (dir.path() / "out").string();
  std::ostringstream out, progress;
  RunOffline(options, out, progress);
  EXPECT_THAT(out.str(), HasSubstr("solver wcsph, adaptive dt <= 0.001 s"));
  EXPECT_THAT(out.str(), HasSubstr("boundary_pressure"));
  const std::vector<std::string> lines =
      Split(ReadFile(fs::path(options.out_dir) / "probes.csv"), '\n');
  // probe_interval 0.005 s: rows at 0, 0.005, ..., 0.02.
  ASSERT_EQ(lines.size(), 1u + 5);
  int previous_step = -1;
  for (size_t r = 1; r < lines.size(); ++r) {
    const std::vector<std::string> cells = Split(lines[r], ',');
    EXPECT_NEAR(std::stod(cells[0]), 0.005 * double(r - 1), 1e-12) << lines[r];
    EXPECT_GT(std::stoi(cells[1]), previous_step + (r > 1 ? 10 : 0));  // many steps per row
    previous_step = std::stoi(cells[1]);
  }
}

TEST(RunOfflineTest, PrintsEveryPassAndTheThroughput) {
  TempDir dir;
  std::ostringstream out, progress;
  RunOffline(SmallRun(dir.path()), out, progress);
  const std::string text = out.str();
  for (const char* pass : {"external_forces", "neighbour_grid", "density", "pressure_force",
                           "viscosity", "integrate"}) {
    EXPECT_THAT(text, HasSubstr(pass));
  }
  EXPECT_THAT(text, HasSubstr("particle-steps/s"));
  EXPECT_THAT(text, HasSubstr("512 particles"));
  EXPECT_THAT(text, HasSubstr("12 steps"));
  EXPECT_THAT(text, HasSubstr("solver seed, dt "));  // the CPU, by default: no device named
  EXPECT_THAT(text, HasSubstr(" threads: "));
  EXPECT_TRUE(progress.str().empty());  // progress is off
}

TEST(RunOfflineTest, VtkEveryTwoFramesWritesTheExpectedFrames) {
  TempDir dir;
  RunOptions options = SmallRun(dir.path());
  options.vtk_every = 2;
  std::ostringstream out, progress;
  RunOffline(options, out, progress);
  const fs::path out_dir(options.out_dir);
  ASSERT_TRUE(fs::exists(out_dir / "frames.pvd"));
  // Frames 0 (t = 0), 2 and 4 of the 4 frames of 12 steps.
  size_t vtp_files = 0;
  for (const auto& entry : fs::recursive_directory_iterator(out_dir)) {
    vtp_files += entry.path().extension() == ".vtp" ? 1 : 0;
  }
  EXPECT_EQ(vtp_files, 3u);
  const std::string pvd = ReadFile(out_dir / "frames.pvd");
  size_t datasets = 0;
  for (size_t at = pvd.find("<DataSet"); at != std::string::npos;
       at = pvd.find("<DataSet", at + 1)) {
    ++datasets;
  }
  EXPECT_EQ(datasets, 3u);
  EXPECT_THAT(out.str(), HasSubstr("frames.pvd"));
}

// seed_basic's frames last 1/60 s (3 steps): the 12 steps' frames end at 1/60 ... 4/60 s.
TEST(RunOfflineTest, VtkFromAndToWriteOnlyTheFramesWithinTheWindow) {
  TempDir dir;
  RunOptions options = SmallRun(dir.path());
  options.vtk_every = 1;
  options.vtk_from = 0.02;  // after frame 1
  options.vtk_to = 0.04;    // before frame 3
  std::ostringstream out, progress;
  RunOffline(options, out, progress);
  const std::string pvd = ReadFile(fs::path(options.out_dir) / "frames.pvd");
  std::vector<std::string> times;
  for (size_t at = pvd.find("timestep=\""); at != std::string::npos;
       at = pvd.find("timestep=\"", at + 1)) {
    times.push_back(pvd.substr(at + 10, pvd.find('"', at + 10) - at - 10));
  }
  ASSERT_EQ(times.size(), 1u) << pvd;
  EXPECT_NEAR(std::stod(times[0]), 2.0 / 60, 1e-9);
}

TEST(RunOfflineTest, VtkToBeforeVtkFromThrowsConfigErrorNamingIt) {
  TempDir dir;
  RunOptions options = SmallRun(dir.path());
  options.vtk_every = 1;
  options.vtk_from = 0.04;
  options.vtk_to = 0.02;
  std::ostringstream out, progress;
  try {
    RunOffline(options, out, progress);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), "--vtk-to");
    EXPECT_THAT(e.what(), HasSubstr("--vtk-from"));
  }
}

TEST(RunOfflineTest, ThreadsOptionGivesTheSameProbes) {
  TempDir dir;
  RunOptions one = SmallRun(dir.path());
  one.threads = 1;
  one.out_dir = (dir.path() / "one").string();
  RunOptions two = one;
  two.threads = 2;
  two.out_dir = (dir.path() / "two").string();
  std::ostringstream out, progress;
  RunOffline(one, out, progress);
  RunOffline(two, out, progress);
  EXPECT_EQ(ReadFile(fs::path(one.out_dir) / "probes.csv"),
            ReadFile(fs::path(two.out_dir) / "probes.csv"));
}

TEST(RunOfflineTest, EndTimeRunsTheFramesUpToIt) {
  TempDir dir;
  RunOptions options = SmallRun(dir.path());
  options.steps.reset();
  options.end_time = 0.1;  // 18 steps of 1/180 s: 6 frames
  std::ostringstream out, progress;
  RunOffline(options, out, progress);
  const std::vector<std::string> lines =
      Split(ReadFile(fs::path(options.out_dir) / "probes.csv"), '\n');
  ASSERT_EQ(lines.size(), 1u + 1 + 6);
  EXPECT_EQ(Split(lines.back(), ',')[1], "18");
}

void ExpectRunConfigError(const RunOptions& options, const std::string& field) {
  std::ostringstream out, progress;
  try {
    RunOffline(options, out, progress);
    ADD_FAILURE() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.field(), field) << e.what();
  }
  EXPECT_FALSE(fs::exists(fs::path(options.out_dir) / "probes.csv"));
}

TEST(RunOfflineTest, UnknownSceneThrowsConfigError) {
  TempDir dir;
  RunOptions options = SmallRun(dir.path());
  options.scene = "no_such_scene";
  ExpectRunConfigError(options, "scene");
}

TEST(RunOfflineTest, BadSetThrowsConfigError) {
  TempDir dir;
  RunOptions options = SmallRun(dir.path());
  options.sets = {"viscosity=-3"};
  ExpectRunConfigError(options, "viscosity");
  options.sets = {"no_such_param=1"};
  ExpectRunConfigError(options, "no_such_param");
  options.sets = {"viscosity"};
  ExpectRunConfigError(options, "--set");
  options.sets = {"particle_quantity=8", "particle_quantity=2.5"};
  ExpectRunConfigError(options, "particle_quantity");
}

// No machine has a 64th GPU (cuda:63, the largest ordinal ParseDevice takes): whatever is
// missing here (the CUDA build, the driver, any GPU, that ordinal), the run fails with
// ConfigError("device") before it writes anything.
TEST(RunOfflineTest, AnUnavailableDeviceThrowsConfigErrorNamingIt) {
  TempDir dir;
  RunOptions options = SmallRun(dir.path());
  options.device = ParseDevice("cuda:63");
  ASSERT_FALSE(DeviceUnavailableReason(options.device).empty());
  ExpectRunConfigError(options, "device");
}

// ---------------------------------------------------------------------------------------------
// The real executable.

using Result = CommandResult;

// Runs `dysa ARGS` through the shell, capturing stdout and stderr into files under `dir`.
Result RunDysa(const fs::path& dir, const std::string& args) {
  return RunCaptured(dir, std::string("'") + DYSA_BINARY + "' " + args);
}

TEST(DysaBinaryTest, RunHelpListsSetAndEveryParameter) {
  TempDir dir;
  const Result r = RunDysa(dir.path(), "run --help");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("--set"));
  for (const ParamDecl& decl : ParamTable()) {
    EXPECT_THAT(r.out, HasSubstr(std::string(decl.name)));
    EXPECT_THAT(r.out, HasSubstr(decl.RangeText())) << decl.name;
    EXPECT_THAT(r.out, HasSubstr("read by " + decl.SolversText())) << decl.name;
  }
  EXPECT_THAT(r.out, HasSubstr("warm_start  [0, 1], default 0.2, read by dfsph"));
  for (const std::string& scene : BuiltinSceneNames()) EXPECT_THAT(r.out, HasSubstr(scene));
}

TEST(DysaBinaryTest, OutOfRangeSetFailsNamingTheParameterAndRange) {
  TempDir dir;
  const fs::path out_dir = dir.path() / "out";
  const Result r = RunDysa(
      dir.path(), "run seed_basic --set viscosity=-3 --steps 1 --out '" + out_dir.string() + "'");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("viscosity"));
  EXPECT_THAT(r.err, HasSubstr(FindParam("viscosity")->RangeText()));
  EXPECT_FALSE(fs::exists(out_dir / "probes.csv"));
}

// A malformed --set is a usage error (2), as for `dysa set NAME` (it exited 1); a value out of
// the parameter's range fails the run (1), as the server's refusal fails `dysa set`.
TEST(DysaBinaryTest, SetExitsAsDysaSetDoes) {
  TempDir dir;
  const std::string run = "run seed_basic --steps 1 --out '" + (dir.path() / "out").string() + "' ";
  Result r = RunDysa(dir.path(), run + "--set viscosity");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--set: expected NAME=VALUE, got 'viscosity'"));
  r = RunDysa(dir.path(), run + "--set viscosity=1e-400");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("viscosity: '1e-400' is too close to 0 for a double"));
  r = RunDysa(dir.path(), run + "--set viscosity=abc");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(RunDysa(dir.path(), "validate --quick --set viscosity").exit_code, 2);
  r = RunDysa(dir.path(), run + "--set iterations_per_frame=2.0000000001");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("iterations_per_frame: 2.0000000001 is not an integer; allowed "
                               "range [1, 100] (integer)"));
}

// A number a double cannot hold gave a raw "[json.exception.out_of_range.406]"; a directory was
// "malformed JSON".
TEST(DysaBinaryTest, SceneFileErrorsNameTheFieldOrThePath) {
  TempDir dir;
  const fs::path scene = dir.path() / "huge.json";
  std::ofstream(scene) << R"({"params": {"viscosity": 1e999}})";
  const std::string out = " --steps 1 --out '" + (dir.path() / "out").string() + "'";
  Result r = RunDysa(dir.path(), "run '" + scene.string() + "'" + out);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("dysa run: error: params.viscosity: 1e999 is out of the range of a "
                               "double (at most 1.8e308 in magnitude) (in " +
                               scene.string() + ")"));
  EXPECT_THAT(r.err, Not(HasSubstr("json.exception")));
  r = RunDysa(dir.path(), "run '" + dir.path().string() + "'" + out);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("is a directory, not a scene file"));
}

// docs/cli.md's table of built-in scenes lists every one (it lacked poiseuille_flow).
TEST(DysaDocsTest, TheBuiltInScenesTableListsEveryScene) {
  const std::string docs = ReadFile(fs::path(DYSA_DOCS_DIR) / "cli.md");
  for (const std::string& scene : BuiltinSceneNames()) {
    EXPECT_THAT(docs, HasSubstr("| `" + scene + "` |")) << scene;
  }
}

TEST(DysaBinaryTest, BogusFlagFails) {
  TempDir dir;
  const Result r = RunDysa(dir.path(), "run seed_basic --no-such-flag");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err + r.out, HasSubstr("--no-such-flag"));
  EXPECT_NE(RunDysa(dir.path(), "").exit_code, 0);                          // no subcommand
  EXPECT_NE(RunDysa(dir.path(), "frobnicate").exit_code, 0);                // unknown subcommand
  EXPECT_NE(RunDysa(dir.path(), "run seed_basic --steps 0").exit_code, 0);  // out of range
  const Result slab = RunDysa(dir.path(), "validate --slab-layers 0");
  EXPECT_NE(slab.exit_code, 0);
  EXPECT_THAT(slab.err + slab.out, HasSubstr("--slab-layers"));
}

// The quick validation with dfsph (seconds since its solves sweep a pair list): the table and
// each case's diagnostics, the tank's largest error located by height and the averaged
// pressure's standard error. dfsph meets every quick bound, so the run exits 0 and says so.
// SPHERIC Test 2 is left out (--case): its quick run takes minutes here, and
// tests/validation/spheric_test2_test.cc covers it.
TEST(DysaBinaryTest, QuickDfsphValidationPrintsEachCasesDiagnostics) {
  TempDir dir;
  const Result r = RunDysa(dir.path(),
                           "validate --quick --solver dfsph --case hydrostatic_tank "
                           "--case dam_break --case poiseuille_flow");
  EXPECT_EQ(r.exit_code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("validate: all targets met"));
  EXPECT_THAT(r.out, HasSubstr("pressure gradient "));
  EXPECT_THAT(r.out, ::testing::ContainsRegex("largest pressure error at y = 0\\.[0-9]+ m "
                                              "\\([0-9]+\\.[0-9] d above the floor, [-+]"));
  EXPECT_THAT(r.out,
              ::testing::ContainsRegex("centre of mass sank -?[0-9]\\.[0-9]{3} d over the run"));
  EXPECT_THAT(r.out, ::testing::ContainsRegex("standard error of the averaged pressure: up to "
                                              "[0-9]\\.[0-9]{2}% of rho0 g H \\(5 batch"));
  EXPECT_THAT(r.out, HasSubstr("front speed dZ/dT"));
  EXPECT_THAT(r.out, HasSubstr("residual height at the wall"));
  EXPECT_THAT(r.out, HasSubstr("dam break front with the gate"));
  EXPECT_THAT(r.out, HasSubstr("poiseuille_flow:"));
  EXPECT_THAT(r.out, Not(HasSubstr("spheric_test2")));
}

// --case runs only the cases named; an unknown one is a usage error listing the cases.
TEST(DysaBinaryTest, ValidateCaseSelectsTheCasesAndRejectsAnUnknownOne) {
  TempDir dir;
  const Result one = RunDysa(dir.path(), "validate --quick --case poiseuille_flow");
  EXPECT_EQ(one.exit_code, 0) << one.out;
  EXPECT_THAT(one.out, HasSubstr("poiseuille (wcsph)"));
  EXPECT_THAT(one.out, HasSubstr("poiseuille (dfsph)"));
  EXPECT_THAT(one.out, Not(HasSubstr("hydrostatic_tank")));
  EXPECT_THAT(one.out, Not(HasSubstr("dam_break")));
  const Result bad = RunDysa(dir.path(), "validate --quick --case tank");
  EXPECT_EQ(bad.exit_code, 2) << bad.err;
  EXPECT_THAT(bad.err, HasSubstr("--case"));
  EXPECT_THAT(bad.err, HasSubstr("no validation case tank; the cases: hydrostatic_tank, "
                                 "dam_break, poiseuille_flow, spheric_test2"));
}

// A missed target fails the command and says which: dfsph starting each solve from all of the
// previous step's pressure (warm_start 1) leaves the quick tank 2.5% off rho0 g (H - y).
TEST(DysaBinaryTest, ValidationThatMissesATargetFailsAndNamesIt) {
  TempDir dir;
  const Result r = RunDysa(
      dir.path(), "validate --quick --solver dfsph --set warm_start=1 --case hydrostatic_tank");
  EXPECT_NE(r.exit_code, 0) << r.out;
  EXPECT_THAT(r.out, ::testing::ContainsRegex("pressure error max / rho0 g H +[0-9.]+% +1\\.00% +"
                                              "MISSED"));
  EXPECT_THAT(r.out, HasSubstr("validate: targets MISSED"));
}

TEST(DysaBinaryTest, BadDeviceIsAUsageErrorNamingTheFlagAndTheForms) {
  TempDir dir;
  const fs::path out_dir = dir.path() / "out";
  for (const char* device : {"bogus", "cuda:99", "cuda:", "gpu"}) {
    const Result r = RunDysa(dir.path(), std::string("run seed_basic --steps 1 --device ") +
                                             device + " --out '" + out_dir.string() + "'");
    EXPECT_EQ(r.exit_code, 2) << device << ": " << r.err;
    EXPECT_THAT(r.err, HasSubstr("--device")) << device;
    EXPECT_THAT(r.err, HasSubstr("use cpu, cuda or cuda:N (N in [0, 63])")) << device;
  }
  const Result validate = RunDysa(dir.path(), "validate --quick --device bogus");
  EXPECT_EQ(validate.exit_code, 2) << validate.err;
  EXPECT_THAT(validate.err, HasSubstr("--device"));
  EXPECT_THAT(validate.err, HasSubstr("use cpu, cuda or cuda:N"));
  EXPECT_FALSE(fs::exists(out_dir / "probes.csv"));
  // --help names the flag and its forms.
  const Result help = RunDysa(dir.path(), "run --help");
  EXPECT_THAT(help.out, HasSubstr("--device"));
  EXPECT_THAT(help.out, HasSubstr("cuda:N"));
}

// A device that parses but cannot run here (cuda:63: no machine has 64 GPUs; on this one, no
// GPU or no CUDA build at all) fails cleanly: exit 2, the flag and value, and what is missing.
TEST(DysaBinaryTest, UnavailableDeviceFailsWithWhatIsMissing) {
  TempDir dir;
  const fs::path out_dir = dir.path() / "out";
  std::vector<std::string> devices = {"cuda:63"};
  if (!DeviceUnavailableReason(ParseDevice("cuda")).empty()) devices.push_back("cuda");
  for (const std::string& device : devices) {
    const Result r = RunDysa(dir.path(), "run seed_basic --steps 1 --device " + device +
                                             " --out '" + out_dir.string() + "'");
    EXPECT_EQ(r.exit_code, 2) << device << ": " << r.err;
    EXPECT_THAT(r.err, HasSubstr("dysa run: error: --device " + device + ": ")) << r.err;
    EXPECT_THAT(r.err, HasSubstr(DeviceUnavailableReason(ParseDevice(device))));
    EXPECT_THAT(r.err, HasSubstr("CUDA"));
    EXPECT_TRUE(r.out.empty()) << r.out;
    EXPECT_FALSE(fs::exists(out_dir / "probes.csv"));
  }
  // validate checks the device before its first case.
  const Result validate = RunDysa(dir.path(), "validate --quick --device cuda:63");
  EXPECT_EQ(validate.exit_code, 2) << validate.err;
  EXPECT_THAT(validate.err, HasSubstr("dysa validate: error: --device cuda:63: "));
  EXPECT_THAT(validate.out, Not(HasSubstr("hydrostatic_tank")));
}

TEST(DysaBinaryTest, ExplicitCpuDeviceRuns) {
  TempDir dir;
  const fs::path out_dir = dir.path() / "out";
  const Result r = RunDysa(
      dir.path(), "run seed_basic --set particle_quantity=6 --steps 3 --device cpu --out '" +
                      out_dir.string() + "'");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("particle-steps/s"));
  EXPECT_TRUE(fs::exists(out_dir / "probes.csv"));
}

TEST(DysaBinaryTest, SmallRunSucceeds) {
  TempDir dir;
  const fs::path out_dir = dir.path() / "out";
  const Result r =
      RunDysa(dir.path(), "run seed_basic --set particle_quantity=6 --steps 6 --out '" +
                              out_dir.string() + "' --vtk-every 1 --threads 1");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("particle-steps/s"));
  EXPECT_TRUE(fs::exists(out_dir / "probes.csv"));
  EXPECT_TRUE(fs::exists(out_dir / "frames.pvd"));
}

}  // namespace
}  // namespace dysa
