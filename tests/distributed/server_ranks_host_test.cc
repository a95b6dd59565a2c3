// The server's simulation thread (SimulationHost) on GPU ranks, on one process with the host
// stand-in for the GPU (host_device_backend.h): what `mpirun dysa-server --device cuda` runs on
// rank 0, without MPI or a GPU. Against a plain host (the CPU, one process) driven by the same
// controls, it reports the same frame, step and state hash, dfsph's scenes included (its ghosts
// refreshed through the device's hook). On a GPU machine under mpirun: mpi_gpu_server_test.sh
// (ctest -L gpu).
#include <gtest/gtest.h>

#include <future>
#include <memory>
#include <string>
#include <vector>

#include "dysa/core/scene.h"
#include "dysa/distributed/ranks_backend.h"
#include "dysa/service/simulation_host.h"
#include "host_device_backend.h"

#if !defined(DYSA_RANKS_SCENE) || !defined(DYSA_RANKS_DFSPH_SCENE)
#error "tests/CMakeLists.txt defines DYSA_RANKS_SCENE and DYSA_RANKS_DFSPH_SCENE"
#endif

namespace dysa::service {
namespace {

HostOptions Paused() {
  HostOptions o;
  o.start_paused = true;
  o.frame_rate = 0;
  o.solver_threads = 1;
  return o;
}

ControlResult Apply(SimulationHost& host, Control control) {
  std::promise<ControlResult> promise;
  auto result = promise.get_future();
  host.Submit(std::move(control), [&](ControlResult r) { promise.set_value(std::move(r)); });
  return result.get();
}

// rank 0 of GPU ranks: its host steps on the ranks' backend, every rank on "cuda:0" (here the
// stand-in).
struct GpuRanksHost {
  GpuRanksHost() {
    runner->set_device_stand_in([](const std::string& solver) {
      return std::make_unique<dysa::testing::HostDeviceBackend>(solver);
    });
    HostOptions options = Paused();
    options.device = ParseDevice("cuda:0");
    options.backend = distributed::RanksBackendFactory(runner);
    host = std::make_unique<SimulationHost>(LoadScene(DYSA_RANKS_SCENE), options);
    host->Start();
  }
  distributed::SingleProcess one;
  std::shared_ptr<distributed::RankRunner> runner = std::make_shared<distributed::RankRunner>(
      one, distributed::BalanceSettings{}, std::vector<Device>{ParseDevice("cuda:0")});
  std::unique_ptr<SimulationHost> host;
};

// Applies `control` to both hosts, expects it applied on both, and the same state after.
void Both(SimulationHost& ranks, SimulationHost& plain, const Control& control, const char* what) {
  const ControlResult a = Apply(ranks, control);
  const ControlResult b = Apply(plain, control);
  ASSERT_EQ(a.code, ControlCode::kOk) << what << ": " << a.message;
  ASSERT_EQ(b.code, ControlCode::kOk) << what << ": " << b.message;
  const HostStatus s = ranks.Status(), t = plain.Status();
  EXPECT_EQ(s.frame, t.frame) << what;
  EXPECT_EQ(s.step, t.step) << what;
  EXPECT_EQ(s.state_hash, t.state_hash) << what;
  EXPECT_NE(s.state_hash, 0u) << what;
}

TEST(ServerRanksHostTest, OnGpuRanksTheServerGivesOneProcesssStates) {
  GpuRanksHost ranks;
  SimulationHost plain(LoadScene(DYSA_RANKS_SCENE), Paused());
  plain.Start();
  EXPECT_EQ(ranks.host->Status().device, "cuda:0, 1 rank");
  Both(*ranks.host, plain, StepControl{3}, "step 3");
  Both(*ranks.host, plain, UpdateParamsControl{{{"kinematic_viscosity", 2e-6}}}, "viscosity");
  Both(*ranks.host, plain, StepControl{2}, "step 2 after the change");
  Both(*ranks.host, plain, StepBackControl{2}, "back 2");
  Both(*ranks.host, plain, StepControl{1}, "step 1 after back");
  Both(*ranks.host, plain, UpdateParamsControl{{{"time_integration", 1}}}, "predictor-corrector");
  Both(*ranks.host, plain, StepControl{2}, "step 2, predictor-corrector");
  Both(*ranks.host, plain, ResetControl{}, "reset");
  Both(*ranks.host, plain, LoadSceneControl{LoadScene(DYSA_RANKS_SCENE)}, "the scene again");
  Both(*ranks.host, plain, StepControl{1}, "step 1 of the loaded scene");
}

TEST(ServerRanksHostTest, OnGpuRanksDfsphRunsAsOnOneProcess) {
  GpuRanksHost ranks;
  SimulationHost plain(LoadScene(DYSA_RANKS_SCENE), Paused());
  plain.Start();
  Both(*ranks.host, plain, StepControl{3}, "step 3");
  Both(*ranks.host, plain, LoadSceneControl{LoadScene(DYSA_RANKS_DFSPH_SCENE)}, "dfsph's scene");
  EXPECT_EQ(ranks.host->Status().device, "cuda:0, 1 rank");
  Both(*ranks.host, plain, StepControl{3}, "dfsph, step 3");
  Both(*ranks.host, plain, StepBackControl{2}, "dfsph, back 2");
  Both(*ranks.host, plain, UpdateParamsControl{{{"kinematic_viscosity", 2e-6}}}, "viscosity");
  Both(*ranks.host, plain, StepControl{2}, "dfsph, step 2 after the change");
  Scene swapped = LoadScene(DYSA_RANKS_SCENE);  // `dysa load SCENE --solver dfsph`
  swapped.solver = "dfsph";
  Both(*ranks.host, plain, LoadSceneControl{swapped}, "the dam break with dfsph");
  Both(*ranks.host, plain, StepControl{2}, "the dam break with dfsph, step 2");
  Both(*ranks.host, plain, ResetControl{}, "reset");
  Both(*ranks.host, plain, StepControl{1}, "step 1 after the reset");
}

}  // namespace
}  // namespace dysa::service
