// Tests of clients/cli/remote_commands.h and dysa/client/client.h: the network verbs of `dysa`
// against a real dysa-server started for each test (on a free port, announced through
// --port-file), through the real `dysa` executable (exit codes, stdout, stderr) and in-process.
#include "remote_commands.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "dysa/client/client.h"
#include "dysa/core/scene.h"
#include "dysa/service/simulation_host.h"
#include "support/server_process.h"
#include "support/temp_dir.h"

#if !defined(DYSA_BINARY) || !defined(DYSA_SERVER_BINARY) || !defined(DYSA_SCENES_DIR)
#error "tests/CMakeLists.txt defines DYSA_BINARY, DYSA_SERVER_BINARY and DYSA_SCENES_DIR"
#endif

namespace dysa::remote {
namespace {

namespace fs = std::filesystem;
using dysa::testing::CommandResult;
using dysa::testing::ReadFile;
using dysa::testing::RunCaptured;
using ::testing::HasSubstr;
using ::testing::Not;
using Json = nlohmann::json;

struct TempDir : dysa::testing::TempDir {
  TempDir() : dysa::testing::TempDir("dysa_remote") {}
};

// seed_basic: 30^3 particles.
constexpr uint32_t kSeedBasicParticles = 27000;

using dysa::testing::Spawn;
using dysa::testing::WaitExit;

// A dysa-server on 127.0.0.1 and a free port (tests/support/server_process.h).
struct ServerProcess : dysa::testing::ServerProcess {
  ServerProcess(const fs::path& dir, std::vector<std::string> args)
      : dysa::testing::ServerProcess(DYSA_SERVER_BINARY, dir, std::move(args)) {}
};

using Result = CommandResult;

// Runs `dysa ARGS` through the shell, capturing stdout and stderr into files under `dir`.
Result RunDysa(const fs::path& dir, const std::string& args, const std::string& env = "") {
  return RunCaptured(dir,
                     "env -u DYSA_TOKEN -u DYSA_SERVER " + env + " '" + DYSA_BINARY + "' " + args);
}

// Checks `text` parses as one JSON object and returns it.
Json ParseJson(const std::string& text) {
  try {
    Json json = Json::parse(text);
    EXPECT_TRUE(json.is_object()) << text;
    return json;
  } catch (const std::exception& e) {
    ADD_FAILURE() << e.what() << " in:\n" << text;
    return Json::object();
  }
}

// Runs /usr/bin/python3 on `script` with `args`; returns its exit status, output in `output`.
int RunPython(const fs::path& dir, const std::string& script, const std::string& args,
              std::string& output) {
  const fs::path file = dir / "check.py";
  std::ofstream(file) << script;
  const fs::path log = dir / "python.txt";
  const std::string command =
      "/usr/bin/python3 '" + file.string() + "' " + args + " >'" + log.string() + "' 2>&1";
  const int status = std::system(command.c_str());
  output = ReadFile(log);
  return (status != -1 && WIFEXITED(status)) ? WEXITSTATUS(status) : -1;
}

// Each test gets a directory and its own server, started paused on seed_basic unless the test
// starts another (no step runs unless the test asks: frame numbers are predictable).
class RemoteTest : public ::testing::Test {
 protected:
  void StartServer(std::vector<std::string> args = {"--scene", "seed_basic", "--paused"}) {
    server_.reset();
    server_ = std::make_unique<ServerProcess>(dir_.path(), std::move(args));
    ASSERT_TRUE(server_->running());
  }
  void SetUp() override { StartServer(); }
  void TearDown() override {
    if (server_) server_->Stop();
  }

  // `dysa --server ADDR ARGS`.
  Result Dysa(const std::string& args, const std::string& env = "") {
    return RunDysa(dir_.path(), "--server " + server_->address() + " " + args, env);
  }
  Json DysaJson(const std::string& args) {
    const Result r = Dysa("--json " + args);
    EXPECT_EQ(r.exit_code, 0) << args << ": " << r.err;
    return ParseJson(r.out);
  }
  ConnectOptions Connect() const {
    ConnectOptions options;
    options.address = server_->address();
    return options;
  }

  TempDir dir_;
  std::unique_ptr<ServerProcess> server_;
};

// ---------------------------------------------------------------------------------------------
// Without a server.

TEST(ParseAssignmentsTest, AcceptsNumbersAndRejectsTheRestNamingTheParameter) {
  const auto values = ParseAssignments(
      {"viscosity=0.01", "gravity=-9.81", "particle_quantity=8", "time_scale=1e-1"});
  ASSERT_EQ(values.size(), 4u);
  EXPECT_EQ(values[0], (std::pair<std::string, double>{"viscosity", 0.01}));
  EXPECT_EQ(values[1].second, -9.81);
  EXPECT_EQ(values[3].second, 0.1);
  for (const char* bad : {"viscosity=abc", "viscosity=", "viscosity=1x", "viscosity=nan",
                          "viscosity=inf", "viscosity= 1", "viscosity=1e-400", "viscosity=1e999"}) {
    try {
      ParseAssignments({bad});
      ADD_FAILURE() << bad << ": no error";
    } catch (const UsageError& e) {
      EXPECT_THAT(e.what(), HasSubstr("viscosity")) << bad;
    }
  }
  EXPECT_THROW(ParseAssignments({"viscosity"}), UsageError);
  EXPECT_THROW(ParseAssignments({"=1"}), UsageError);
  EXPECT_THROW(ParseAssignments({}), UsageError);
  EXPECT_THROW(ParseAssignments({"viscosity=1", "viscosity=2"}), UsageError);
}

TEST(ParseFieldsTest, AlwaysIncludesPositions) {
  EXPECT_EQ(ParseFields({}), uint32_t(codec::kPositions));
  EXPECT_EQ(ParseFields({"speed"}), uint32_t(codec::kPositions | codec::kSpeed));
  EXPECT_EQ(ParseFields({"velocity", "density", "positions"}),
            uint32_t(codec::kPositions | codec::kVelocity | codec::kDensity));
  EXPECT_THROW(ParseFields({"pressure"}), UsageError);
}

TEST(StatusCodeNameTest, NamesEveryCode) {
  EXPECT_EQ(StatusCodeName(0), "OK");
  EXPECT_EQ(StatusCodeName(3), "INVALID_ARGUMENT");
  EXPECT_EQ(StatusCodeName(14), "UNAVAILABLE");
  EXPECT_EQ(StatusCodeName(16), "UNAUTHENTICATED");
  EXPECT_EQ(StatusCodeName(99), "CODE_99");
}

TEST(DysaRemoteBinaryTest, ConnectionRefusedNamesTheAddress) {
  TempDir dir;
  // Port 1 (tcpmux) is privileged and not served here: the connection is refused.
  const Result r = RunDysa(dir.path(), "--server 127.0.0.1:1 status");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("dysa status: error: UNAVAILABLE: "));
  EXPECT_THAT(r.err, HasSubstr("127.0.0.1:1"));
  EXPECT_TRUE(r.out.empty()) << r.out;
  // DYSA_SERVER replaces the default address.
  const Result env = RunDysa(dir.path(), "params", "DYSA_SERVER=127.0.0.1:1");
  EXPECT_EQ(env.exit_code, 1);
  EXPECT_THAT(env.err, HasSubstr("127.0.0.1:1"));
}

// dysa-server --device: a bad value, or a device that cannot run (cuda:63: no machine has 64
// GPUs; on this one, maybe no GPU or no CUDA build at all), stops it before it listens: exit 2
// and a message naming the flag and what is wrong.
TEST(DysaServerBinaryTest, AnUnusableDeviceStopsItBeforeItListens) {
  TempDir dir;
  const fs::path port_file = dir.path() / "port";
  const auto server = [&](const std::string& device) {
    return RunCaptured(dir.path(), std::string("'") + DYSA_SERVER_BINARY +
                                       "' --listen 127.0.0.1:0 --port-file '" + port_file.string() +
                                       "' --device " + device);
  };
  Result r = server("bogus");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_THAT(r.err, HasSubstr("dysa-server: error: --device bogus: "));
  EXPECT_THAT(r.err, HasSubstr("use cpu, cuda or cuda:N (N in [0, 63])"));
  r = server("cuda:63");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_THAT(r.err, HasSubstr("dysa-server: error: --device cuda:63: "));
  EXPECT_THAT(r.err, HasSubstr("CUDA"));
  EXPECT_FALSE(fs::exists(port_file));
  const Result help = RunCaptured(dir.path(), std::string("'") + DYSA_SERVER_BINARY + "' --help");
  EXPECT_THAT(help.out, HasSubstr("--device"));
}

TEST(DysaRemoteBinaryTest, UsageErrorsExitWithTwoBeforeAnyCall) {
  TempDir dir;
  // No server listens at 127.0.0.1:1, so an exit status of 2 (not 1) shows no call was made.
  const std::string server = "--server 127.0.0.1:1 ";
  for (const char* args : {"step 0",
                           "back -1",
                           "set",
                           "set viscosity",
                           "set viscosity=abc",
                           "load",
                           "record --frames 5",
                           "record --out x.npz",
                           "record --frames 0 --out x.npz",
                           "record --frames 1 --out x.npz --format csv",
                           "watch --fields pressure",
                           "watch --seconds 0",
                           "status --no-such-flag",
                           "frobnicate",
                           "step 10001",
                           "back 10001",
                           "set viscosity=1e-400",
                           "set viscosity=1e999",
                           "set viscosity=inf",
                           "watch --fps-target 0",
                           "watch --fps-target 5000",
                           "watch --byte-budget 10",
                           "watch --byte-budget 100000",
                           "watch --particle-budget 0",
                           "watch --view 1,2,3"}) {
    const Result r = RunDysa(dir.path(), server + args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.err << r.out;
  }
  Result r = RunDysa(dir.path(), server + "set viscosity=abc");
  EXPECT_THAT(r.err, HasSubstr("dysa set: error: viscosity: 'abc' is not a number"));
  // An underflow is not "not a finite number" (it was).
  r = RunDysa(dir.path(), server + "set viscosity=1e-400");
  EXPECT_THAT(r.err, HasSubstr("dysa set: error: viscosity: '1e-400' is too close to 0 for a "
                               "double (it would round to 0)"));
  r = RunDysa(dir.path(), server + "set viscosity=1e999");
  EXPECT_THAT(r.err, HasSubstr("'1e999' is out of the range of a double"));
  // The server's limit, not 1,000,000 the server refuses.
  EXPECT_EQ(kMaxStepFrames, service::kMaxStepCount);
  r = RunDysa(dir.path(), server + "step 10001");
  EXPECT_THAT(r.err + r.out, HasSubstr("not in range 1 to 10000"));
  // Budgets: the flag and its range, or what it needs.
  r = RunDysa(dir.path(), server + "watch --fps-target 5000");
  EXPECT_THAT(r.err + r.out, HasSubstr("--fps-target: Value 5000 not in range"));
  r = RunDysa(dir.path(), server + "record --frames 1 --out x.npz --byte-budget 100000");
  EXPECT_THAT(r.err, HasSubstr("dysa record: error: --byte-budget: needs --fps-target"));
  // Not "A subcommand is required".
  r = RunDysa(dir.path(), server + "frobnicate");
  EXPECT_THAT(r.err, HasSubstr("dysa: error: unknown command 'frobnicate'; the commands are run, "
                               "validate, status,"));
  // --help lists the verbs.
  const Result help = RunDysa(dir.path(), "--help");
  EXPECT_EQ(help.exit_code, 0);
  for (const char* verb : {"run", "status", "pause", "resume", "step", "back", "reset", "params",
                           "set", "load", "scenes", "scene", "watch", "record"}) {
    EXPECT_THAT(help.out, HasSubstr(verb));
  }
  // validate names each of its cases.
  EXPECT_THAT(
      help.out,
      HasSubstr("(hydrostatic tank, Martin & Moyce dam break, Poiseuille flow, SPHERIC Test 2)"));
}

// ---------------------------------------------------------------------------------------------
// Against a server.

TEST_F(RemoteTest, StatusPrintsATableAndJson) {
  ASSERT_EQ(Dysa("step 2").exit_code, 0);  // so that every pass has been timed
  const Result r = Dysa("status");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("seed_basic"));
  EXPECT_THAT(r.out, HasSubstr("paused"));
  EXPECT_THAT(r.out, HasSubstr(std::to_string(kSeedBasicParticles)));
  EXPECT_THAT(r.out, HasSubstr("last ms"));
  EXPECT_THAT(r.out, HasSubstr("mean ms"));
  EXPECT_THAT(r.out, HasSubstr("density"));
  EXPECT_THAT(r.out, HasSubstr("total"));
  EXPECT_THAT(r.out, ::testing::ContainsRegex("\ndevice +cpu\n"));

  // --json before or after the verb.
  for (const char* args : {"--json status", "status --json"}) {
    const Result j = Dysa(args);
    ASSERT_EQ(j.exit_code, 0) << j.err;
    const Json s = ParseJson(j.out);
    EXPECT_EQ(s.value("scene", ""), "seed_basic");
    EXPECT_EQ(s.value("solver", ""), "seed");
    EXPECT_EQ(s.value("state", ""), "paused");
    EXPECT_EQ(s.value("particles", 0u), kSeedBasicParticles);
    EXPECT_EQ(s.value("frame", 0u), 2u);
    EXPECT_EQ(s.value("step", 0u), 6u);  // 3 steps per frame
    EXPECT_EQ(s.value("device", ""), "cpu");
    EXPECT_EQ(s.value("device_memory_bytes", 1u), 0u);
    ASSERT_TRUE(s.contains("passes") && s["passes"].is_array());
    EXPECT_FALSE(s["passes"].empty());
    for (const Json& p : s["passes"]) {
      EXPECT_TRUE(p.contains("name") && p.contains("last_ms") && p.contains("mean_ms")) << p;
    }
  }
}

TEST_F(RemoteTest, PauseResumeStepAndBackMoveTheFrame) {
  Json r = DysaJson("pause");
  EXPECT_EQ(r["status"]["state"], "paused");
  const uint64_t start = r["status"]["frame"];
  EXPECT_EQ(start, 0u);  // started paused

  r = DysaJson("step 3");
  EXPECT_EQ(r["frames_moved"], 3);
  EXPECT_EQ(r["status"]["frame"], start + 3);
  EXPECT_EQ(r["status"]["state"], "paused");

  r = DysaJson("back 2");
  EXPECT_EQ(r["frames_moved"], 2);
  EXPECT_EQ(r["status"]["frame"], start + 1);

  // Default counts: one frame.
  r = DysaJson("step");
  EXPECT_EQ(r["status"]["frame"], start + 2);
  r = DysaJson("back");
  EXPECT_EQ(r["status"]["frame"], start + 1);

  // Human output says what happened.
  Result h = Dysa("step 3");
  ASSERT_EQ(h.exit_code, 0) << h.err;
  EXPECT_THAT(h.out, HasSubstr("stepped 3 frames to frame " + std::to_string(start + 4)));
  h = Dysa("back 100");  // more than the history holds
  ASSERT_EQ(h.exit_code, 0) << h.err;
  EXPECT_THAT(h.out, HasSubstr("to frame 0"));
  EXPECT_THAT(h.out, HasSubstr("no older frame"));

  h = Dysa("resume");
  ASSERT_EQ(h.exit_code, 0) << h.err;
  EXPECT_THAT(h.out, HasSubstr("running"));
  EXPECT_EQ(DysaJson("status")["state"], "running");
  h = Dysa("pause");
  EXPECT_THAT(h.out, HasSubstr("paused at frame"));

  r = DysaJson("reset");
  EXPECT_EQ(r["status"]["frame"], 0u);
  EXPECT_EQ(r["status"]["time"], 0.0);
  EXPECT_TRUE(r["reset"].get<bool>());
}

TEST_F(RemoteTest, ParamsListsEveryParameterWithUnitRangeAndResetFlag) {
  const Result r = Dysa("params");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("needs reset"));
  EXPECT_THAT(r.out, HasSubstr("read by"));
  EXPECT_THAT(r.out, HasSubstr("wcsph, dfsph"));
  EXPECT_THAT(r.out, HasSubstr("viscosity"));
  EXPECT_THAT(r.out, HasSubstr("m^3/s"));
  EXPECT_THAT(r.out, HasSubstr("particle_quantity"));
  EXPECT_THAT(r.out, HasSubstr("integer"));

  const Json j = DysaJson("params");
  ASSERT_TRUE(j["params"].is_array());
  bool viscosity = false, quantity = false;
  for (const Json& p : j["params"]) {
    if (p["name"] == "viscosity") {
      viscosity = true;
      EXPECT_EQ(p["value"], 0.001);
      EXPECT_EQ(p["unit"], "m^3/s");
      EXPECT_LE(p["min"].get<double>(), 0.001);
      EXPECT_GE(p["max"].get<double>(), 0.001);
      EXPECT_FALSE(p["needs_reset"].get<bool>());
      EXPECT_EQ(p["solvers"], Json::array({"seed"}));
    }
    if (p["name"] == "particle_quantity") {
      quantity = true;
      EXPECT_TRUE(p["integer"].get<bool>());
      EXPECT_TRUE(p["needs_reset"].get<bool>());
    }
  }
  EXPECT_TRUE(viscosity && quantity) << j;
}

double ParamValue(const Json& params, const std::string& name) {
  for (const Json& p : params["params"]) {
    if (p["name"] == name) return p["value"];
  }
  ADD_FAILURE() << "no parameter " << name;
  return 0;
}

TEST_F(RemoteTest, SetChangesParametersAllOrNothing) {
  Result r = Dysa("set viscosity=0.01");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("viscosity = 0.01 m^3/s"));
  EXPECT_THAT(r.out, HasSubstr("no reset"));
  EXPECT_EQ(ParamValue(DysaJson("params"), "viscosity"), 0.01);

  // Out of range: INVALID_ARGUMENT naming the field; nothing applied.
  r = Dysa("set viscosity=-3");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("dysa set: error: INVALID_ARGUMENT: "));
  EXPECT_THAT(r.err, HasSubstr("viscosity"));
  r = Dysa("set viscosity=0.02 particle_quantity=2.5");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("particle_quantity"));
  EXPECT_EQ(ParamValue(DysaJson("params"), "viscosity"), 0.01);

  // Unknown name.
  r = Dysa("set no_such_param=1");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("dysa set: error: "));
  EXPECT_THAT(r.err, HasSubstr("no_such_param"));

  // Not a number: refused before any call.
  r = Dysa("set viscosity=abc");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("viscosity"));

  // A parameter that needs a reset re-spawns the fluid.
  const Json j = DysaJson("set particle_quantity=10 viscosity=0.005");
  EXPECT_TRUE(j["reset"].get<bool>());
  EXPECT_EQ(j["changed"]["particle_quantity"], 10.0);
  EXPECT_EQ(j["changed"]["viscosity"], 0.005);
  EXPECT_EQ(j["status"]["particles"], 1000);
  r = Dysa("set particle_quantity=12");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("reset: the fluid was re-spawned"));
}

TEST_F(RemoteTest, LoadSceneByNameAndFromAFile) {
  Result r = Dysa("load seed_obstacles");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("loaded scene seed_obstacles"));
  EXPECT_EQ(DysaJson("status")["scene"], "seed_obstacles");
  r = Dysa("load seed_basic");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(DysaJson("status")["scene"], "seed_basic");

  // A file's text: a smaller copy of seed_basic under another name.
  Json scene = Json::parse(ReadFile(fs::path(DYSA_SCENES_DIR) / "seed_basic.json"));
  scene["name"] = "small_from_file";
  scene["params"]["particle_quantity"] = 10;
  const fs::path file = dir_.path() / "small.json";
  std::ofstream(file) << scene.dump(2);
  const Json j = DysaJson("load '" + file.string() + "'");
  EXPECT_EQ(j["status"]["scene"], "small_from_file");
  EXPECT_EQ(j["status"]["particles"], 1000);

  // A bad scene file fails naming the field; the old scene keeps running.
  scene["fluid_blocks"][0]["spacing"] = -1;
  const fs::path bad = dir_.path() / "bad.json";
  std::ofstream(bad) << scene.dump(2);
  r = Dysa("load '" + bad.string() + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("dysa load: error: INVALID_ARGUMENT: "));
  EXPECT_THAT(r.err, HasSubstr("spacing"));
  std::ofstream(dir_.path() / "broken.json") << "{\"name\": ";
  r = Dysa("load '" + (dir_.path() / "broken.json").string() + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("INVALID_ARGUMENT"));
  r = Dysa("load no_such_scene");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("dysa load: error: 'no_such_scene' is neither a file here nor a "
                               "built-in scene of the server (dysa scenes lists them)"));
  // A missing file is not an unknown built-in name to send as json_text (it was).
  r = Dysa("load missing.json");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("dysa load: error: no such file 'missing.json'"));
  EXPECT_THAT(r.err, Not(HasSubstr("json_text")));
  r = Dysa("load '" + (dir_.path() / "no_dir" / "x").string() + "'");
  EXPECT_THAT(r.err, HasSubstr("no such file"));
  r = Dysa("load '" + dir_.path().string() + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("is a directory, not a scene file"));

  const Json s = DysaJson("status");
  EXPECT_EQ(s["scene"], "small_from_file");
  EXPECT_EQ(s["particles"], 1000);
}

TEST_F(RemoteTest, ScenesListsTheBuiltInsAndMarksTheCurrent) {
  const Result r = Dysa("scenes");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("* seed_basic"));
  EXPECT_THAT(r.out, HasSubstr("seed_obstacles"));
  const Json j = DysaJson("scenes");
  EXPECT_EQ(j["current"], "seed_basic");
  std::vector<std::string> names;
  for (const Json& s : j["scenes"]) names.push_back(s["name"]);
  EXPECT_THAT(names, ::testing::IsSupersetOf({"seed_basic", "seed_obstacles", "seed_test_scene"}));
}

TEST_F(RemoteTest, SceneShowsTheGeometryAndJson) {
  Result r = Dysa("scene");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("seed_basic"));
  EXPECT_THAT(r.out, HasSubstr("seed (registered: seed"));
  EXPECT_THAT(r.out, HasSubstr("[-5, -3, -5] to [5, 3, 5] m (10 x 6 x 10 m)"));
  EXPECT_THAT(r.out, HasSubstr("particle radius"));
  EXPECT_THAT(r.out, HasSubstr("obstacles"));

  // --solver names a registered solver; an unknown one fails and the scene stays.
  r = Dysa("load seed_obstacles --solver seed");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("loaded scene seed_obstacles"));
  EXPECT_THAT(r.out, HasSubstr("solver seed"));
  r = Dysa("load seed_basic --solver nope");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("dysa load: error: INVALID_ARGUMENT: solver: "));
  EXPECT_THAT(r.err, HasSubstr("nope"));

  r = Dysa("scene");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("seed_obstacles"));
  EXPECT_THAT(r.out, HasSubstr("sphere"));
  EXPECT_THAT(r.out, HasSubstr("centre [0.5, -1.8, 0.8] m, radius 1 m"));
  EXPECT_THAT(r.out, HasSubstr("box"));

  const Json j = DysaJson("scene");
  EXPECT_EQ(j["name"], "seed_obstacles");
  EXPECT_EQ(j["solver"], "seed");
  EXPECT_THAT(j["solvers"].get<std::vector<std::string>>(), ::testing::Contains("seed"));
  EXPECT_EQ(j["domain_min"], Json::array({-5.0, -3.0, -3.0}));
  EXPECT_EQ(j["domain_max"], Json::array({5.0, 3.0, 3.0}));
  ASSERT_EQ(j["spheres"].size(), 1u);
  EXPECT_EQ(j["spheres"][0]["center"], Json::array({0.5, -1.8, 0.8}));
  EXPECT_EQ(j["spheres"][0]["radius"], 1.0);
  ASSERT_EQ(j["boxes"].size(), 1u);
  EXPECT_EQ(j["boxes"][0]["min"].size(), 3u);
  EXPECT_DOUBLE_EQ(j["particle_radius"].get<double>(), 0.5 * 4.0 / 23);
  EXPECT_EQ(j["scene_version"], DysaJson("status")["scene_version"]);
}

// A sphere moving at 1.5 m/s over [0.1, 0.5] s, a static box, and a box on a keyframed path.
constexpr const char* kMovingObstaclesScene = R"({
  "name": "moving_obstacles",
  "fluid_blocks": [{"center": [-3.5, -2, 0], "size": [1, 1, 1], "particles_per_axis": [5, 5, 5]}],
  "obstacles": [
    {"type": "sphere", "center": [2, 0, 0], "radius": 0.5,
     "motion": {"velocity": [0, 1.5, 0], "start": 0.1, "end": 0.5}},
    {"type": "box", "center": [0, -2, 0], "size": [1, 1, 1]},
    {"type": "box", "center": [0, 1, 0], "size": [1, 0.5, 1],
     "motion": {"path": [[0, 0, 0, 0], [0.2, 1, 0, 0.5], [0.4, -1, 0, 0]]}}
  ]
})";

void ExpectSameMotion(const ObstacleMotion& got, const dysa::ObstacleMotion& sent) {
  ASSERT_EQ(got.keys.size(), sent.keys.size());
  for (size_t i = 0; i < got.keys.size(); ++i) {
    EXPECT_EQ(got.keys[i].time, sent.keys[i].time) << "key " << i;
    for (int a = 0; a < 3; ++a) {
      EXPECT_EQ(got.keys[i].displacement[a], sent.keys[i].displacement[a]) << "key " << i;
    }
  }
}

// Scene text with motion, loaded over the RPC: GetScene gives every key back as ParseScene has
// it, `dysa scene` says which obstacles move, and a bad motion fails naming its field.
TEST_F(RemoteTest, SceneShowsObstacleMotion) {
  const fs::path file = dir_.path() / "moving.json";
  std::ofstream(file) << kMovingObstaclesScene;
  Result r = Dysa("load '" + file.string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;

  const dysa::Scene sent = dysa::ParseScene(kMovingObstaclesScene);
  Client client(Connect());
  const SceneDescription scene = client.GetScene();
  ASSERT_EQ(scene.spheres.size(), 1u);
  ASSERT_EQ(scene.boxes.size(), 2u);
  EXPECT_TRUE(scene.spheres[0].motion.moving());
  ExpectSameMotion(scene.spheres[0].motion, sent.spheres[0].motion);
  EXPECT_FALSE(scene.boxes[0].motion.moving());
  ExpectSameMotion(scene.boxes[1].motion, sent.boxes[1].motion);
  // Positions stay the scene's, without displacement.
  EXPECT_EQ(scene.boxes[1].min, (std::array<double, 3>{-0.5, 0.75, -0.5}));
  // A reset and a re-spawn keep the motion.
  ASSERT_EQ(Dysa("reset").exit_code, 0);
  ASSERT_EQ(Dysa("set particle_quantity=6").exit_code, 0);
  ExpectSameMotion(client.GetScene().boxes[1].motion, sent.boxes[1].motion);

  r = Dysa("scene");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("centre [2, 0, 0] m, radius 0.5 m, moves: 2 keys, t 0.1-0.5 s, "
                               "up to 0.6 m away\n"));
  EXPECT_THAT(r.out, HasSubstr("[-0.5, -2.5, -0.5] to [0.5, -1.5, 0.5] m\n"));
  EXPECT_THAT(r.out, HasSubstr("[-0.5, 0.75, -0.5] to [0.5, 1.25, 0.5] m, moves: 3 keys, "
                               "t 0-0.4 s, up to 1.11803 m away\n"));

  const Json j = DysaJson("scene");
  EXPECT_EQ(j["spheres"][0]["motion"]["path"],
            Json::parse("[[0.1, 0, 0, 0], [0.5, 0, 0.6000000000000001, 0]]"));
  EXPECT_FALSE(j["boxes"][0].contains("motion"));
  EXPECT_EQ(j["boxes"][1]["motion"]["path"],
            Json::parse("[[0, 0, 0, 0], [0.2, 1, 0, 0.5], [0.4, -1, 0, 0]]"));

  // The core parser's error reaches the client with the field's path; the scene stays.
  const uint64_t version = client.GetStatus().scene_version;
  Json bad = Json::parse(kMovingObstaclesScene);
  bad["obstacles"][2]["motion"]["path"][1][0] = 0;
  std::ofstream(dir_.path() / "bad.json") << bad.dump();
  r = Dysa("load '" + (dir_.path() / "bad.json").string() + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(
      r.err, HasSubstr("dysa load: error: INVALID_ARGUMENT: scene: obstacles[2].motion.path[1][0]: "
                       "key times must strictly increase; 0 s follows 0 s"));
  bad = Json::parse(kMovingObstaclesScene);
  bad["obstacles"][0]["motion"]["velocity"] = {0, 2e4, 0};
  try {
    client.LoadSceneText(bad.dump(), "");
    ADD_FAILURE() << "no error";
  } catch (const RpcError& e) {
    EXPECT_EQ(e.code_name(), "INVALID_ARGUMENT");
    EXPECT_THAT(e.message(), HasSubstr("obstacles[0].motion.velocity[1]: 20000 is outside the "
                                       "allowed range [-10000, 10000] m/s"));
  }
  EXPECT_EQ(client.GetStatus().scene_version, version);
  EXPECT_EQ(client.GetScene().name, "moving_obstacles");
}

TEST_F(RemoteTest, InProcessVerbsPrintToTheirStream) {
  Client client(Connect());
  std::ostringstream out;
  PrintStatus(client, /*json=*/true, out);
  EXPECT_EQ(ParseJson(out.str())["particles"], kSeedBasicParticles);
  out.str("");
  const SceneDescription scene = client.GetScene();
  EXPECT_EQ(scene.name, "seed_basic");
  EXPECT_EQ(scene.domain_min, (std::array<double, 3>{-5, -3, -5}));
  EXPECT_GT(scene.particle_radius, 0);
  EXPECT_EQ(scene.scene_version, client.GetStatus().scene_version);
  PrintScene(client, /*json=*/false, out);
  EXPECT_THAT(out.str(), HasSubstr("particle radius"));
  out.str("");
  RunControl(client, ControlVerb::kStep, 2, /*json=*/false, out);
  EXPECT_THAT(out.str(), HasSubstr("stepped 2 frames to frame 2"));
  out.str("");
  try {
    SetParams(client, {"gravity=1e9"}, false, out);
    ADD_FAILURE() << "no error";
  } catch (const RpcError& e) {
    EXPECT_EQ(e.code_name(), "INVALID_ARGUMENT");
    EXPECT_THAT(e.message(), HasSubstr("gravity"));
  }
  EXPECT_TRUE(out.str().empty());
}

TEST_F(RemoteTest, WatchPrintsFramesAndStopsAfterSeconds) {
  StartServer({"--scene", "seed_basic"});  // running
  const auto start = std::chrono::steady_clock::now();
  const Result r = Dysa("watch --seconds 2");
  const double took =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_GE(took, 1.9);
  EXPECT_LT(took, 30);
  // Not a terminal: what runs where, a line a second, then a summary.
  EXPECT_THAT(r.out, HasSubstr("watching seed_basic (solver seed) on cpu\n"));
  EXPECT_THAT(r.out, HasSubstr("frame "));
  EXPECT_THAT(r.out, HasSubstr(std::to_string(kSeedBasicParticles) + " particles"));
  EXPECT_THAT(r.out, HasSubstr("frames/s"));
  EXPECT_THAT(r.out, HasSubstr("B/particle"));
  EXPECT_THAT(r.out, HasSubstr("latency"));
  EXPECT_THAT(r.out, HasSubstr("watched "));
  EXPECT_THAT(r.out, HasSubstr(", the first after "));
  EXPECT_THAT(r.out, Not(HasSubstr("\r")));

  const Json j = DysaJson("watch --seconds 1.5 --fields velocity --stride 3");
  EXPECT_GT(j["frames"].get<uint64_t>(), 0u) << j;
  EXPECT_EQ(j["particles"], kSeedBasicParticles / 3);
  EXPECT_EQ(j["decode_errors"], 0);
  EXPECT_EQ(j["device"], "cpu");
  // The first frame came after the stream opened, within the watch.
  EXPECT_GT(j["first_frame_s"].get<double>(), 0) << j;
  EXPECT_LT(j["first_frame_s"].get<double>(), j["seconds"].get<double>()) << j;
}

TEST_F(RemoteTest, WatchEndsCleanlyOnCtrlC) {
  StartServer({"--scene", "seed_basic"});
  const fs::path log = dir_.path() / "watch.txt";
  const pid_t pid = Spawn(DYSA_BINARY, {"--server", server_->address(), "watch"}, log);
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  kill(pid, SIGINT);
  EXPECT_EQ(WaitExit(pid), 0) << ReadFile(log);
  EXPECT_THAT(ReadFile(log), HasSubstr("watched "));
}

TEST_F(RemoteTest, WatchFailsWithUnavailableWhenTheServerShutsDown) {
  StartServer({"--scene", "seed_basic"});
  const fs::path log = dir_.path() / "watch.txt";
  const pid_t pid = Spawn(DYSA_BINARY, {"--server", server_->address(), "watch"}, log);
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  server_->Stop(SIGINT);
  EXPECT_EQ(WaitExit(pid), 1) << ReadFile(log);
  EXPECT_THAT(ReadFile(log), HasSubstr("dysa watch: error: UNAVAILABLE: "));
}

TEST_F(RemoteTest, RecordInterruptedWritesTheFramesReceived) {
  StartServer({"--scene", "seed_basic"});
  const fs::path npz = dir_.path() / "part.npz";
  const fs::path log = dir_.path() / "record.txt";
  const pid_t pid = Spawn(DYSA_BINARY,
                          {"--server", server_->address(), "record", "--frames", "100000",
                           "--stride", "10", "--out", npz.string()},
                          log);
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  kill(pid, SIGINT);
  EXPECT_EQ(WaitExit(pid), 1) << ReadFile(log);
  const std::string text = ReadFile(log);
  EXPECT_THAT(text, HasSubstr("dysa record: error: interrupted after "));
  EXPECT_THAT(text, HasSubstr(" of 100000 frames; they are in " + npz.string()));
  std::string output;
  EXPECT_EQ(RunPython(dir_.path(), R"(import sys
import numpy as np
d = np.load(sys.argv[1])
F = d['time'].shape[0]
assert F >= 1 and d['positions'].shape == (F, 2700, 3), d['positions'].shape
print('ok')
)",
                      "'" + npz.string() + "'", output),
            0)
      << output << text;
}

TEST_F(RemoteTest, RecordNpzLoadsWithNumpy) {
  StartServer({"--scene", "seed_basic"});
  const fs::path npz = dir_.path() / "rec.npz";
  Result r = Dysa("record --frames 5 --format npz --out '" + npz.string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("recorded 5 frames"));
  ASSERT_TRUE(fs::exists(npz));
  std::string output;
  EXPECT_EQ(RunPython(dir_.path(), R"(import sys
import numpy as np
d = np.load(sys.argv[1])
assert sorted(d.files) == ['frame', 'ids', 'positions', 'speed', 'step', 'time'], d.files
F, N = 5, 27000
assert d['positions'].shape == (F, N, 3) and d['positions'].dtype == np.float32
assert d['speed'].shape == (F, N) and d['speed'].dtype == np.float32
assert d['time'].shape == (F,) and d['time'].dtype == np.float64
assert d['step'].dtype == np.uint64 and d['frame'].dtype == np.uint64
assert np.all(np.diff(d['frame'].astype(np.int64)) > 0), d['frame']
assert np.all(np.diff(d['time']) > 0), d['time']
assert np.all(d['step'] == 3 * d['frame']), (d['step'], d['frame'])
assert np.array_equal(d['ids'], np.arange(N, dtype=np.uint32))
p = d['positions']
assert np.all(np.isfinite(p)) and np.all(p >= -5.01) and np.all(p <= 5.01)
print('ok')
)",
                      "'" + npz.string() + "'", output),
            0)
      << output;

  // Other fields and a stride: velocity (F, N/10, 3) and density, ids 0, 10, 20, ...
  const fs::path npz2 = dir_.path() / "rec2.npz";
  const Json j = DysaJson("record --frames 3 --fields velocity,density --stride 10 --out '" +
                          npz2.string() + "'");  // npz from the extension
  EXPECT_EQ(j["frames"], 3);
  EXPECT_EQ(j["format"], "npz");
  EXPECT_EQ(RunPython(dir_.path(), R"(import sys
import numpy as np
d = np.load(sys.argv[1])
assert sorted(d.files) == ['density', 'frame', 'ids', 'positions', 'step', 'time', 'velocity']
assert d['velocity'].shape == (3, 2700, 3) and d['density'].shape == (3, 2700)
assert np.array_equal(d['ids'], 10 * np.arange(2700))
assert np.all(d['density'] > 0)
print('ok')
)",
                      "'" + npz2.string() + "'", output),
            0)
      << output;
}

TEST_F(RemoteTest, RecordNpzWithAParticleBudgetKeepsAnEvenSubsetAndItsIds) {
  StartServer({"--scene", "seed_basic"});
  const fs::path npz = dir_.path() / "budget.npz";
  const Json j = DysaJson("record --frames 3 --particle-budget 3000 --out '" + npz.string() + "'");
  EXPECT_EQ(j["frames"], 3);
  std::string output;
  EXPECT_EQ(
      RunPython(dir_.path(), R"(import sys
import numpy as np
sys.path.insert(0, sys.argv[2])
from dysa import detail
d = np.load(sys.argv[1])
ids = d['ids']
assert 2000 < len(ids) <= 3000, len(ids)
assert d['positions'].shape == (3, len(ids), 3)
assert np.all(np.diff(ids.astype(np.int64)) > 0)
# The subset by rank: the ids whose rank is below a threshold, not every n-th id.
assert detail.detail_rank(ids).max() < detail.detail_rank(np.setdiff1d(np.arange(27000), ids)).min()
assert len(set((ids % 9).tolist())) == 9
print('ok')
)",
                "'" + npz.string() + "' '" +
                    (fs::path(DYSA_SCENES_DIR).parent_path() / "clients/python").string() + "'",
                output),
      0)
      << output;
  // dysa watch shows the detail.
  const Json w = DysaJson("watch --seconds 1 --particle-budget 3000");
  EXPECT_LT(w["detail"].get<double>(), 0.12);
  EXPECT_LE(w["particles"].get<int>(), 3000);
  // With a camera the stream is view-dependent; a bad one is refused naming the field.
  const Json v = DysaJson("watch --seconds 1 --particle-budget 3000 --view 0,2,12,0,-1,0,40");
  EXPECT_LE(v["particles"].get<int>(), 3000);
  const Result bad = Dysa("watch --seconds 1 --particle-budget 3000 --view 0,2,12,0,-1,0,500");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_THAT(bad.err, HasSubstr("fov_y_deg: allowed range [1, 179] degrees"));
}

TEST_F(RemoteTest, RecordVtkWritesASeries) {
  StartServer({"--scene", "seed_basic"});
  const fs::path out = dir_.path() / "series";
  const Result r = Dysa("record --frames 3 --format vtk --out '" + out.string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("series.pvd"));
  ASSERT_TRUE(fs::exists(dir_.path() / "series.pvd"));
  const std::string pvd = ReadFile(dir_.path() / "series.pvd");
  for (int f = 0; f < 3; ++f) {
    const std::string file = "series/frame_00000" + std::to_string(f) + ".vtp";
    EXPECT_TRUE(fs::exists(dir_.path() / file)) << file;
    EXPECT_THAT(pvd, HasSubstr(file));
  }
  EXPECT_FALSE(fs::exists(dir_.path() / "series" / "frame_000003.vtp"));
  const std::string vtp = ReadFile(dir_.path() / "series" / "frame_000000.vtp");
  EXPECT_THAT(vtp, HasSubstr("NumberOfPoints=\"27000\""));
  EXPECT_THAT(vtp, HasSubstr("Name=\"speed\""));
  EXPECT_THAT(vtp, HasSubstr("Name=\"id\""));
  EXPECT_THAT(vtp, Not(HasSubstr("Name=\"pressure\"")));  // not streamed

  // An OUT ending in .pvd names the collection itself.
  const Result r2 = Dysa("record --frames 1 --out '" + (dir_.path() / "one.pvd").string() + "'");
  ASSERT_EQ(r2.exit_code, 0) << r2.err;
  EXPECT_TRUE(fs::exists(dir_.path() / "one.pvd"));
  EXPECT_TRUE(fs::exists(dir_.path() / "one" / "frame_000000.vtp"));
}

// As `dysa run --out` does; it failed with "no directory".
TEST_F(RemoteTest, RecordMakesMissingDirectories) {
  Result r =
      Dysa("record --frames 1 --out '" + (dir_.path() / "new" / "sub" / "x.npz").string() + "'");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir_.path() / "new" / "sub" / "x.npz"));
  r = Dysa("record --frames 1 --out '" + (dir_.path() / "vtk_new" / "series").string() + "'");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir_.path() / "vtk_new" / "series.pvd"));
  // A directory that cannot be made fails before streaming.
  std::ofstream(dir_.path() / "a_file") << "x";
  r = Dysa("record --frames 1 --out '" + (dir_.path() / "a_file" / "x.npz").string() + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("dysa record: error: cannot write"));
  EXPECT_THAT(r.err, HasSubstr("cannot make the directory"));
}

TEST_F(RemoteTest, TokenIsNeededForControlsWhenTheServerHasOne) {
  const fs::path token = dir_.path() / "token";
  std::ofstream(token) << "s3cret-token\n";
  StartServer({"--scene", "seed_basic", "--paused", "--token-file", token.string()});

  Result r = Dysa("pause");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("dysa pause: error: UNAUTHENTICATED: "));
  EXPECT_THAT(r.err, HasSubstr("--token"));
  r = Dysa("--token wrong set viscosity=0.01");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("UNAUTHENTICATED"));

  r = Dysa("--token s3cret-token step 1");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  r = Dysa("step 1 --token s3cret-token");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  r = Dysa("set viscosity=0.01", "DYSA_TOKEN=s3cret-token");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(DysaJson("status")["frame"], 2);  // watching needs no token without --protect-watch
}

TEST_F(RemoteTest, ProtectWatchNeedsTheTokenForStatusToo) {
  const fs::path token = dir_.path() / "token";
  std::ofstream(token) << "s3cret-token";
  StartServer(
      {"--scene", "seed_basic", "--paused", "--token-file", token.string(), "--protect-watch"});
  Result r = Dysa("status");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("dysa status: error: UNAUTHENTICATED"));
  r = Dysa("--token s3cret-token status");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  r = Dysa("watch --seconds 1");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("dysa watch: error: UNAUTHENTICATED"));
}

TEST_F(RemoteTest, TlsWithTheServersCertificateAsCa) {
  if (!fs::exists("/usr/bin/openssl")) GTEST_SKIP() << "no /usr/bin/openssl to make a certificate";
  // A self-signed certificate for the name "localhost" only, so that reaching the server as
  // 127.0.0.1 needs --tls-name. (Not "--server localhost:PORT": that resolves the name through
  // c-ares, which leaks a few bytes at exit and fails the sanitizer build.)
  const fs::path cert = dir_.path() / "cert.pem", key = dir_.path() / "key.pem";
  const std::string command =
      "/usr/bin/openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj /CN=localhost "
      "-addext subjectAltName=DNS:localhost -keyout '" +
      key.string() + "' -out '" + cert.string() + "' >/dev/null 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  StartServer({"--scene", "seed_basic", "--paused", "--tls-cert", cert.string(), "--tls-key",
               key.string()});
  const std::string ca = "--tls-ca '" + cert.string() + "' ";

  Result r = Dysa(ca + "--tls-name localhost status");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("seed_basic"));
  r = Dysa(ca + "--tls-name localhost step 1");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  // The certificate does not name 127.0.0.1.
  r = Dysa(ca + "--timeout 10 status");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("dysa status: error: "));
  // Plaintext to a TLS server fails.
  r = Dysa("--timeout 10 status");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("dysa status: error: "));
  // A CA file that does not exist is a usage error.
  r = Dysa("--tls-ca '" + (dir_.path() / "missing.pem").string() + "' status");
  EXPECT_EQ(r.exit_code, 2);
}

}  // namespace
}  // namespace dysa::remote
