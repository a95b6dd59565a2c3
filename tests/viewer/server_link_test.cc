// Tests of viewer/src/server_link.cc against a real dysa-server: the view the panel draws from
// (status, parameters, scene), commands in order, server errors shown to the user, and the
// link following a server that goes away and comes back.
#include "server_link.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "support/server_process.h"
#include "support/temp_dir.h"
#include "support/wait_for.h"

#ifndef DYSA_SERVER_BINARY
#error "tests/CMakeLists.txt defines DYSA_SERVER_BINARY"
#endif

namespace dysa::viewer {
namespace {

using dysa::testing::ServerProcess;
using dysa::testing::WaitFor;
using ::testing::HasSubstr;
using Clock = std::chrono::steady_clock;

const remote::ParamInfo* Find(const ServerView& view, const std::string& name) {
  auto it = std::find_if(view.params.begin(), view.params.end(),
                         [&](const remote::ParamInfo& p) { return p.name == name; });
  return it == view.params.end() ? nullptr : &*it;
}

// A server started paused on seed_basic and a link to it that has fetched everything.
class ServerLinkTest : public ::testing::Test {
 protected:
  void SetUp() override {
    server_ = std::make_unique<ServerProcess>(
        DYSA_SERVER_BINARY, dir_.path(),
        std::vector<std::string>{"--scene", "seed_basic", "--paused"});
    ASSERT_TRUE(server_->running());
    remote::ConnectOptions connect;
    connect.address = server_->address();
    link_ = std::make_unique<ServerLink>(connect, std::chrono::milliseconds(50));
    link_->Start();
    ASSERT_TRUE(WaitFor([&] {
      const ServerView v = link_->View();
      return v.connected && !v.params.empty() && v.scene.has_value() && !v.scenes.empty();
    }));
  }

  dysa::testing::TempDir dir_{"dysa_link"};
  std::unique_ptr<ServerProcess> server_;
  std::unique_ptr<ServerLink> link_;
};

TEST_F(ServerLinkTest, ViewHoldsStatusEveryParameterAndTheScene) {
  const ServerView view = link_->View();
  EXPECT_EQ(view.status.state, "paused");
  EXPECT_EQ(view.status.particles, 27000u);
  // The thesis's sliders, with ranges and units from the server's declarations.
  for (const char* name :
       {"time_scale", "iterations_per_frame", "gravity", "collision_damping", "smoothing_radius",
        "target_density", "pressure_multiplier", "near_pressure_multiplier", "viscosity",
        "particle_quantity", "spawn_size", "spawn_jitter"}) {
    const remote::ParamInfo* p = Find(view, name);
    ASSERT_NE(p, nullptr) << name;
    EXPECT_LT(p->min, p->max) << name;
  }
  EXPECT_EQ(Find(view, "smoothing_radius")->unit, "m");
  EXPECT_EQ(view.scene->name, "seed_basic");
  EXPECT_EQ(view.scene->domain_min[1], -3);
  EXPECT_EQ(view.scene->domain_max[1], 3);
  EXPECT_GT(view.scene->particle_radius, 0);
  EXPECT_THAT(view.scene->solvers, ::testing::Contains("seed"));
}

// The panel shows the running solver's parameters only (ParamInfo::ReadBy): seed_basic's
// sliders are the thesis's, without the physical solvers'.
TEST_F(ServerLinkTest, ParametersSayWhichSolversReadThem) {
  const ServerView view = link_->View();
  ASSERT_EQ(view.status.solver, "seed");
  for (const char* name : {"time_scale", "iterations_per_frame", "gravity", "viscosity"})
    EXPECT_TRUE(Find(view, name)->ReadBy("seed")) << name;
  for (const char* name : {"rest_density", "speed_of_sound", "warm_start", "gravity_ramp_time"})
    EXPECT_FALSE(Find(view, name)->ReadBy("seed")) << name;
  EXPECT_EQ(Find(view, "warm_start")->solvers, std::vector<std::string>{"dfsph"});
  EXPECT_TRUE(Find(view, "gravity_ramp_time")->ReadBy("dfsph"));
  EXPECT_FALSE(Find(view, "viscosity")->ReadBy("dfsph"));
  EXPECT_EQ(Find(view, "time_scale")->solvers, view.scene->solvers);  // every solver
  // Nothing known (an older server, no status yet): every parameter shows.
  EXPECT_TRUE(remote::ParamInfo{}.ReadBy("seed"));
  EXPECT_TRUE(Find(view, "warm_start")->ReadBy(""));
}

TEST_F(ServerLinkTest, CommandsApplyInOrder) {
  link_->Step(3);
  link_->StepBack(2);
  link_->WaitIdle();
  EXPECT_EQ(link_->View().status.frame, 1u);
  link_->TogglePause();  // paused -> running
  link_->WaitIdle();
  EXPECT_EQ(link_->View().status.state, "running");
  link_->TogglePause();
  link_->WaitIdle();
  EXPECT_EQ(link_->View().status.state, "paused");
  link_->Reset();
  link_->WaitIdle();
  EXPECT_EQ(link_->View().status.frame, 0u);
  EXPECT_TRUE(link_->View().messages.empty());
}

TEST_F(ServerLinkTest, ParameterChangeRefreshesTheParameters) {
  const uint64_t revision = link_->View().params_revision;
  link_->SetParam("viscosity", 0.02);
  link_->WaitIdle();
  const ServerView view = link_->View();
  EXPECT_GT(view.params_revision, revision);
  EXPECT_DOUBLE_EQ(Find(view, "viscosity")->value, 0.02);
  EXPECT_TRUE(view.messages.empty());
}

TEST_F(ServerLinkTest, ResettingChangeIsAnnouncedAndRefetchesTheScene) {
  const ServerView before = link_->View();
  link_->SetParam("particle_quantity", 20);
  link_->WaitIdle();
  ASSERT_TRUE(WaitFor([&] { return link_->View().scene_revision > before.scene_revision; }, 10));
  const ServerView view = link_->View();
  EXPECT_EQ(view.status.particles, 8000u);
  ASSERT_FALSE(view.messages.empty());
  EXPECT_FALSE(view.messages.back().error);
  EXPECT_THAT(view.messages.back().text, HasSubstr("reset"));
  // Fewer particles over the same spawn cube: larger spacing, larger drawn radius.
  EXPECT_GT(view.scene->particle_radius, before.scene->particle_radius);
}

TEST_F(ServerLinkTest, ServerErrorsReachTheUserAndChangeNothing) {
  link_->SetParam("viscosity", -1);
  link_->LoadScene("no_such_scene");
  link_->WaitIdle();
  const ServerView view = link_->View();
  ASSERT_EQ(view.messages.size(), 2u);
  EXPECT_TRUE(view.messages[0].error);
  EXPECT_THAT(view.messages[0].text, HasSubstr("viscosity"));
  EXPECT_THAT(view.messages[0].text, HasSubstr("INVALID_ARGUMENT"));
  EXPECT_THAT(view.messages[1].text, HasSubstr("no_such_scene"));
  EXPECT_DOUBLE_EQ(Find(view, "viscosity")->value, 0.001);
  EXPECT_EQ(view.scene->name, "seed_basic");
  link_->DismissMessages();
  EXPECT_TRUE(link_->View().messages.empty());
}

TEST_F(ServerLinkTest, LoadingASceneRefetchesIt) {
  link_->LoadScene("seed_obstacles");
  link_->WaitIdle();
  ASSERT_TRUE(WaitFor(
      [&] {
        const ServerView v = link_->View();
        return v.scene && v.scene->name == "seed_obstacles";
      },
      10));
  const ServerView view = link_->View();
  EXPECT_FALSE(view.scene->spheres.empty() && view.scene->boxes.empty());
}

TEST_F(ServerLinkTest, FollowsTheServerAwayAndBack) {
  const int port = server_->port();
  const uint64_t revision = link_->View().params_revision;
  server_.reset();
  ASSERT_TRUE(WaitFor([&] { return !link_->View().connected; }, 10));
  EXPECT_FALSE(link_->View().connection_error.empty());
  // A command while away fails with a message instead of hanging the queue.
  link_->Step(1);
  link_->WaitIdle();
  EXPECT_FALSE(link_->View().messages.empty());

  server_ = std::make_unique<ServerProcess>(
      DYSA_SERVER_BINARY, dir_.path(),
      std::vector<std::string>{"--scene", "seed_basic", "--paused"}, port);
  ASSERT_TRUE(server_->running());
  ASSERT_TRUE(WaitFor(
      [&] {
        const ServerView v = link_->View();
        return v.connected && v.params_revision > revision;
      },
      30));
}

}  // namespace
}  // namespace dysa::viewer
