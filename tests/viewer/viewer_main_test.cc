// Tests of viewer/main.cc: the real dysa-viewer binary on a private Xvfb display (Mesa's
// software OpenGL) against a real dysa-server. --screenshot renders a settled pool in both
// render modes; the PNG must have the asked size and show the fluid in the lower part of the box.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <stb/stb_image.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "dysa/client/client.h"
#include "support/server_process.h"
#include "support/temp_dir.h"
#include "support/wait_for.h"
#include "support/xvfb_display.h"

#if !defined(DYSA_VIEWER_BINARY) || !defined(DYSA_SERVER_BINARY)
#error "tests/CMakeLists.txt defines DYSA_VIEWER_BINARY and DYSA_SERVER_BINARY"
#endif

namespace {

using dysa::testing::CommandResult;
using dysa::testing::RunCaptured;
using dysa::testing::ServerProcess;
using dysa::testing::Spawn;
using dysa::testing::WaitFor;
using dysa::testing::XvfbDisplay;
using ::testing::HasSubstr;

// A pool at rest: a slab of fluid filling the bottom of the thesis's default domain
// ([-5, 5] x [-3, 3] x [-5, 5]), 3,456 particles, so the frame at t = 0 is already settled.
constexpr const char* kPoolScene = R"({
  "name": "pool",
  "fluid_blocks": [{"center": [0, -2, 0], "size": [9, 1.9, 9],
                    "particles_per_axis": [24, 6, 24], "jitter": 0}]
})";

// Under the asan preset, the viewer runs without leak detection: Mesa's software driver, loaded
// with dlopen and unloaded at exit, leaves about 5 kB that LeakSanitizer cannot attribute (its
// frames have no frame pointers, so no suppression can name them). Memory errors are still
// caught, and the viewer's own threads are leak-checked in frame_receiver_test and
// server_link_test. Harmless in release builds.
constexpr const char* kViewerAsanOptions = "ASAN_OPTIONS=detect_leaks=0";

constexpr int kWidth = 480;
constexpr int kHeight = 360;

struct Image {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> rgb;
  const uint8_t* At(int x, int y) const { return &rgb[3 * (size_t(y) * width + x)]; }
};

Image LoadPng(const std::string& path) {
  Image image;
  int channels = 0;
  uint8_t* data = stbi_load(path.c_str(), &image.width, &image.height, &channels, 3);
  if (data == nullptr) {
    ADD_FAILURE() << "cannot read " << path << ": " << stbi_failure_reason();
    return image;
  }
  image.rgb.assign(data, data + size_t(image.width) * image.height * 3);
  stbi_image_free(data);
  return image;
}

// Water colour: clearly bluer than it is red, and not the near-black background.
bool IsFluidColoured(const uint8_t* p) { return p[2] > p[0] + 30 && p[2] > 70; }

class ViewerMainTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_FALSE(display_.display().empty());
    const std::string scene = (dir_.path() / "pool.json").string();
    std::ofstream(scene) << kPoolScene;
    server_ = std::make_unique<ServerProcess>(
        DYSA_SERVER_BINARY, dir_.path(), std::vector<std::string>{"--scene", scene, "--paused"});
    ASSERT_TRUE(server_->running());
  }

  CommandResult RunViewer(const std::string& args) {
    return RunCaptured(dir_.path(), "env DISPLAY=" + display_.display() +
                                        " LIBGL_ALWAYS_SOFTWARE=1 " + kViewerAsanOptions + " '" +
                                        DYSA_VIEWER_BINARY + "' " + args);
  }

  // Renders a screenshot in `mode` (with `extra` flags) and checks what it shows; returns the
  // fluid-coloured pixels of its lower half.
  int CheckScreenshot(const std::string& mode, const std::string& extra = "",
                      const std::string& particles = "3456 particles") {
    const std::string png = (dir_.path() / (mode + std::to_string(extra.size()) + ".png")).string();
    const CommandResult r =
        RunViewer("--server " + server_->address() + " --screenshot '" + png +
                  "' --frames 3 --width " + std::to_string(kWidth) + " --height " +
                  std::to_string(kHeight) + " --mode " + mode + " " + extra);
    EXPECT_EQ(r.exit_code, 0) << r.err << r.out;
    if (r.exit_code != 0) return 0;
    EXPECT_THAT(r.out, HasSubstr(particles));
    const Image image = LoadPng(png);
    EXPECT_EQ(image.width, kWidth);
    EXPECT_EQ(image.height, kHeight);
    if (image.width != kWidth || image.height != kHeight) return 0;

    // Enough pixels differ from the background (the top-left corner, outside the box).
    const uint8_t* background = image.At(0, 0);
    int differing = 0;
    int fluid_top = 0;
    int fluid_bottom = 0;
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        const uint8_t* p = image.At(x, y);
        if (std::abs(p[0] - background[0]) + std::abs(p[1] - background[1]) +
                std::abs(p[2] - background[2]) >
            24) {
          ++differing;
        }
        if (IsFluidColoured(p)) ++(y < kHeight / 2 ? fluid_top : fluid_bottom);
      }
    }
    const int pixels = kWidth * kHeight;
    EXPECT_GT(differing, pixels / 20) << mode;
    // The pool lies in the lower part of the box: fluid colours fill much of the lower half
    // of the picture and little of the upper half.
    EXPECT_GT(fluid_bottom, pixels / 20) << mode;
    EXPECT_LT(fluid_top, fluid_bottom / 4) << mode;
    return fluid_bottom;
  }

  XvfbDisplay display_{"1024x768x24"};
  dysa::testing::TempDir dir_{"dysa_viewer"};
  std::unique_ptr<ServerProcess> server_;
};

TEST_F(ViewerMainTest, ScreenshotShowsTheSettledPoolAsParticles) { CheckScreenshot("particles"); }

TEST_F(ViewerMainTest, ScreenshotShowsTheSettledPoolAsAFluidSurface) { CheckScreenshot("fluid"); }

TEST_F(ViewerMainTest, AtAParticleBudgetTheLargerParticlesStillCoverThePool) {
  // An eighth of the particles (a stable, even subset), each drawn twice as large (volume
  // scaling): the pool covers much the same part of the picture as at full detail.
  for (const std::string mode : {"particles", "fluid"}) {
    const int full = CheckScreenshot(mode);
    const int budget = CheckScreenshot(mode, "--particle-budget 432", "particles");
    // Measured: 0.73 (particles, whose shaded rims are darker) and 1.01 (fluid) of full detail;
    // at the particles' own radius 0.42 and 0.46.
    EXPECT_GT(budget, 0.6 * full) << mode;
    EXPECT_LT(budget, 1.3 * full) << mode;
  }
  const CommandResult r = RunViewer("--byte-budget 100000");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--byte-budget: needs --fps-target"));
}

TEST_F(ViewerMainTest, ScreenshotPanelAddsTheControlsOnTheRight) {
  const std::string plain = (dir_.path() / "plain.png").string();
  const std::string panel = (dir_.path() / "panel.png").string();
  const std::string common =
      "--server " + server_->address() + " --frames 2 --width 800 --height 600";
  CommandResult r = RunViewer(common + " --screenshot '" + plain + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = RunViewer(common + " --screenshot '" + panel + "' --screenshot-panel");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Image a = LoadPng(plain);
  const Image b = LoadPng(panel);
  ASSERT_EQ(a.rgb.size(), b.rgb.size());
  // The panel opens 430 pixels from the right edge, 420 wide; below the status overlay (the top
  // 200 rows) the 360 columns left of it keep the scene.
  int right = 0;
  int left = 0;
  for (int y = 200; y < 600; ++y) {
    for (int x = 0; x < 800; ++x) {
      if (std::memcmp(a.At(x, y), b.At(x, y), 3) != 0) ++(x >= 360 ? right : left);
    }
  }
  EXPECT_GT(right, 420 * 400 / 4);
  EXPECT_LT(left, 360 * 400 / 100);
}

// Neutral grey, brighter than the background: the obstacles' colour (the domain box's lines
// are bluer and thin).
bool IsObstacleGrey(const uint8_t* p) {
  return p[0] > 60 && std::abs(p[0] - p[1]) < 12 && std::abs(p[2] - p[0]) < 16;
}

int CountGrey(const Image& image) {
  int grey = 0;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) grey += IsObstacleGrey(image.At(x, y));
  }
  return grey;
}

TEST_F(ViewerMainTest, ScreenshotDrawsTheObstacles) {
  const std::string pool_png = (dir_.path() / "pool.png").string();
  const std::string common = " --frames 2 --width " + std::to_string(kWidth) + " --height " +
                             std::to_string(kHeight) + " --screenshot ";
  CommandResult r = RunViewer("--server " + server_->address() + common + "'" + pool_png + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;

  // seed_obstacles: a sphere of radius 1 m and a 1 x 1.5 x 1.6 m box on the floor.
  const std::filesystem::path other = dir_.path() / "obstacles";
  std::filesystem::create_directories(other);
  ServerProcess obstacles(DYSA_SERVER_BINARY, other, {"--scene", "seed_obstacles", "--paused"});
  ASSERT_TRUE(obstacles.running());
  const std::string obstacles_png = (dir_.path() / "obstacles.png").string();
  r = RunViewer("--server " + obstacles.address() + common + "'" + obstacles_png + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;

  const int pool_grey = CountGrey(LoadPng(pool_png));
  const int obstacles_grey = CountGrey(LoadPng(obstacles_png));
  EXPECT_GT(obstacles_grey, kWidth * kHeight / 100);
  EXPECT_GT(obstacles_grey, 4 * pool_grey + 500);
}

// A 1.5 m box that moves 6 m along +x in the first 0.05 s (3 frames of 1/60 s), above a few
// particles in a corner.
constexpr const char* kMovingBoxScene = R"({
  "name": "moving_box",
  "domain": {"min": [-5, -3, -3], "max": [5, 3, 3]},
  "fluid_blocks": [{"center": [0, -2.6, -2.5], "size": [1, 0.4, 0.4],
                    "particles_per_axis": [5, 2, 2]}],
  "obstacles": [{"type": "box", "center": [-3, 0.5, 0], "size": [1.5, 1.5, 1.5],
                 "motion": {"path": [[0, 0, 0, 0], [0.05, 6, 0, 0]]}}]
})";

// Where `image` shows obstacle grey and `other` does not: their count and mean column.
struct GreyOnly {
  int pixels = 0;
  double mean_x = 0;
};

GreyOnly GreyNotIn(const Image& image, const Image& other) {
  GreyOnly g;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      if (IsObstacleGrey(image.At(x, y)) && !IsObstacleGrey(other.At(x, y))) {
        ++g.pixels;
        g.mean_x += x;
      }
    }
  }
  if (g.pixels > 0) g.mean_x /= g.pixels;
  return g;
}

// A moving obstacle is drawn where its motion has it at the shown frame's time: it moves across
// the view as frames are stepped, and stepping back or resetting puts it where it was.
TEST_F(ViewerMainTest, ScreenshotsShowAMovingBoxWhereItIsAtTheFramesTime) {
  const std::filesystem::path other = dir_.path() / "moving";
  std::filesystem::create_directories(other);
  const std::string scene = (other / "moving_box.json").string();
  std::ofstream(scene) << kMovingBoxScene;
  ServerProcess moving(DYSA_SERVER_BINARY, other, {"--scene", scene, "--paused"});
  ASSERT_TRUE(moving.running());
  dysa::remote::ConnectOptions connect;
  connect.address = moving.address();
  dysa::remote::Client client(connect);
  auto screenshot = [&](const std::string& name) {
    const std::string png = (dir_.path() / (name + ".png")).string();
    const CommandResult r =
        RunViewer("--server " + moving.address() + " --frames 2 --width " + std::to_string(kWidth) +
                  " --height " + std::to_string(kHeight) + " --screenshot '" + png + "'");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return LoadPng(png);
  };

  const Image start = screenshot("start");  // t = 0: the box at the left
  ASSERT_EQ(client.Step(3).status.frame, 3u);
  const Image moved = screenshot("moved");  // t = 0.05 s: 6 m to the right
  ASSERT_EQ(client.StepBack(2).status.frame, 1u);
  const Image back = screenshot("back");  // t = 1/60 s: 2 m to the right
  ASSERT_EQ(client.Reset().status.frame, 0u);
  const Image reset = screenshot("reset");
  ASSERT_EQ(start.rgb.size(), moved.rgb.size());
  ASSERT_EQ(start.rgb.size(), back.rgb.size());
  ASSERT_EQ(start.rgb.size(), reset.rgb.size());

  // The 1.5 m box covers about 45 x 45 pixels; the domain is 10 m across about 280.
  const int box_pixels = kWidth * kHeight / 200;
  const GreyOnly left = GreyNotIn(start, moved);
  const GreyOnly right = GreyNotIn(moved, start);
  EXPECT_GT(left.pixels, box_pixels);
  EXPECT_GT(right.pixels, box_pixels);
  EXPECT_GT(right.mean_x, left.mean_x + kWidth / 5);  // 6 m: about 170 pixels
  // A third of the way along after stepping back: between the two.
  const GreyOnly middle = GreyNotIn(back, start);
  EXPECT_GT(middle.pixels, box_pixels);
  EXPECT_GT(middle.mean_x, left.mean_x + kWidth / 20);
  EXPECT_LT(middle.mean_x, right.mean_x - kWidth / 20);
  // After the reset, where it started.
  EXPECT_LT(GreyNotIn(reset, start).pixels, box_pixels / 20);
  EXPECT_LT(GreyNotIn(start, reset).pixels, box_pixels / 20);
}

TEST_F(ViewerMainTest, ScreenshotWithoutAServerFailsWithTheReason) {
  const CommandResult r = RunViewer("--server 127.0.0.1:1 --screenshot '" +
                                    (dir_.path() / "none.png").string() + "' --timeout 2");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("no particle frame within 2 s"));
  EXPECT_THAT(r.err, HasSubstr("127.0.0.1:1"));
}

// Waits up to `seconds` for the child `pid` to exit: its exit status, or -2 if it still runs
// (it is then killed).
int WaitExitWithin(pid_t pid, double seconds) {
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  int status = 0;
  while (waitpid(pid, &status, WNOHANG) != pid) {
    if (std::chrono::steady_clock::now() > give_up) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      return -2;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// A --screenshot viewer whose parent died (a test or script killed while it waits for frames)
// exits within seconds, though its own --timeout is far off.
TEST_F(ViewerMainTest, AScreenshotViewerWhoseParentIsGoneExits) {
  // This process adopts the orphan (PR_SET_CHILD_SUBREAPER), so it can wait for its exit.
  ASSERT_EQ(prctl(PR_SET_CHILD_SUBREAPER, 1), 0);
  int fds[2];
  ASSERT_EQ(pipe(fds), 0);
  const std::filesystem::path log = dir_.path() / "orphan.log";
  const pid_t parent = fork();
  if (parent == 0) {  // the viewer's parent: starts it, then dies
    setenv("DISPLAY", display_.display().c_str(), 1);
    setenv("ASAN_OPTIONS", "detect_leaks=0", 1);  // see kViewerAsanOptions
    const pid_t viewer = Spawn(DYSA_VIEWER_BINARY,
                               {"--server", "127.0.0.1:1", "--timeout", "600", "--screenshot",
                                (dir_.path() / "orphan.png").string()},
                               log);
    (void)!write(fds[1], &viewer, sizeof viewer);
    std::this_thread::sleep_for(std::chrono::seconds(1));  // the viewer is up and waiting
    _exit(0);
  }
  close(fds[1]);
  pid_t viewer = -1;
  ASSERT_EQ(read(fds[0], &viewer, sizeof viewer), ssize_t(sizeof viewer));
  close(fds[0]);
  EXPECT_EQ(dysa::testing::WaitExit(parent), 0);
  EXPECT_EQ(WaitExitWithin(viewer, 10), 1) << dysa::testing::ReadFile(log);
  EXPECT_THAT(dysa::testing::ReadFile(log), HasSubstr("screenshot"));
  prctl(PR_SET_CHILD_SUBREAPER, 0);
}

TEST_F(ViewerMainTest, BadFlagsNameTheFlagAndItsRange) {
  CommandResult r = RunViewer("--mode sparkles");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("--mode"));
  r = RunViewer("--width 10");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("--width"));
  EXPECT_THAT(r.err, HasSubstr("64"));
}

// Runs `xdotool ARGS` on the test's display; true when it exits 0.
bool Xdotool(const std::string& display, const std::string& args) {
  return std::system(("DISPLAY=" + display + " xdotool " + args + " >/dev/null 2>&1").c_str()) == 0;
}

// An interactive viewer on the test's display, focused and streaming from the test's server.
class InteractiveViewer {
 public:
  InteractiveViewer(const std::string& display, const std::string& address,
                    const std::filesystem::path& dir, std::vector<std::string> extra = {})
      : display_(display), log_(dir / "viewer.log") {
    setenv("DISPLAY", display.c_str(), 1);
    setenv("ASAN_OPTIONS", "detect_leaks=0", 1);  // see kViewerAsanOptions
    std::vector<std::string> args = {"--server", address, "--width",       "640",
                                     "--height", "480",   "--capture-dir", dir.string()};
    args.insert(args.end(), extra.begin(), extra.end());
    pid_ = Spawn(DYSA_VIEWER_BINARY, args, log_);
    unsetenv("DISPLAY");
    unsetenv("ASAN_OPTIONS");
    dysa::remote::ConnectOptions connect;
    connect.address = address;
    dysa::remote::Client client(connect);
    // Ready once its window is mapped and focused, and its stream is open. Focusing can fail
    // while the window is being mapped, so it is retried.
    ready_ = WaitFor([&] {
               return Xdotool(display,
                              "search --sync --onlyvisible --name 'DySAQUASIMs viewer' "
                              "windowfocus --sync");
             }) &&
             WaitFor([&] { return client.GetStatus().subscribers > 0; });
  }
  ~InteractiveViewer() {
    if (pid_ > 0) Quit();
  }
  bool ready() const { return ready_; }
  std::string log() const { return dysa::testing::ReadFile(log_); }
  // The exit status once it exits by itself within `seconds`; -2 (killed) if it does not.
  int WaitForExit(double seconds) {
    const int status = WaitExitWithin(pid_, seconds);
    pid_ = -1;
    return status;
  }
  // Events to the focused viewer window, e.g. "key space".
  bool Send(const std::string& xdotool_args) const { return Xdotool(display_, xdotool_args); }
  // SIGTERM closes the window and exits cleanly, like closing it by hand: the exit status.
  int Quit() {
    kill(pid_, SIGTERM);
    const int status = dysa::testing::WaitExit(pid_);
    pid_ = -1;
    return status;
  }

 private:
  std::string display_;
  std::filesystem::path log_;
  pid_t pid_ = -1;
  bool ready_ = false;
};

// An interactive viewer whose server is gone for longer than --server-timeout exits, saying so,
// rather than polling a dead address forever.
TEST_F(ViewerMainTest, AnInteractiveViewerExitsWhenItsServerIsGone) {
  InteractiveViewer viewer(display_.display(), server_->address(), dir_.path(),
                           {"--server-timeout", "1"});
  ASSERT_TRUE(viewer.ready()) << viewer.log();
  server_->Stop();
  EXPECT_EQ(viewer.WaitForExit(15), 1) << viewer.log();
  EXPECT_THAT(viewer.log(), HasSubstr("lost the server"));
}

// The interactive viewer steered with real key presses (XTEST events through xdotool): Space
// resumes and pauses, Right steps a frame, Left steps back, R resets.
TEST_F(ViewerMainTest, KeysSteerTheServer) {
  InteractiveViewer viewer(display_.display(), server_->address(), dir_.path());
  ASSERT_TRUE(viewer.ready()) << viewer.log();
  dysa::remote::ConnectOptions connect;
  connect.address = server_->address();
  dysa::remote::Client client(connect);

  auto frame = [&] { return client.GetStatus().frame; };
  ASSERT_TRUE(viewer.Send("key space"));
  EXPECT_TRUE(WaitFor([&] { return frame() >= 10; }));  // running
  ASSERT_TRUE(viewer.Send("key space"));
  EXPECT_TRUE(WaitFor([&] { return client.GetStatus().state == "paused"; }));
  const uint64_t paused_at = frame();

  ASSERT_TRUE(viewer.Send("key Right Right Right"));
  EXPECT_TRUE(WaitFor([&] { return frame() == paused_at + 3; })) << frame();
  ASSERT_TRUE(viewer.Send("key Left"));
  EXPECT_TRUE(WaitFor([&] { return frame() == paused_at + 2; })) << frame();
  ASSERT_TRUE(viewer.Send("key r"));
  EXPECT_TRUE(WaitFor([&] { return frame() == 0; })) << frame();
  EXPECT_EQ(client.GetStatus().state, "paused");

  EXPECT_EQ(viewer.Quit(), 0) << viewer.log();
}
// F12 saves the view; a left drag orbits the camera; the view follows the window's size.
TEST_F(ViewerMainTest, MouseOrbitsAndTheViewFollowsTheWindowSize) {
  InteractiveViewer viewer(display_.display(), server_->address(), dir_.path());
  ASSERT_TRUE(viewer.ready()) << viewer.log();
  auto capture = [&](int n) {
    const std::filesystem::path png = dir_.path() / ("dysa-viewer-" + std::to_string(n) + ".png");
    EXPECT_TRUE(viewer.Send("key F12"));
    EXPECT_TRUE(WaitFor([&] {
      return viewer.log().find("saved " + png.string()) != std::string::npos;
    })) << viewer.log();
    return LoadPng(png.string());
  };
  // Wait until the pool is drawn (the first frame may still be on its way).
  Image before;
  int n = 0;
  ASSERT_TRUE(WaitFor(
      [&] {
        before = capture(++n);
        int fluid = 0;
        for (int y = 0; y < before.height; ++y) {
          for (int x = 0; x < before.width; ++x) fluid += IsFluidColoured(before.At(x, y));
        }
        return fluid > 1000;
      },
      30));
  ASSERT_EQ(before.width, 640);

  // Drag left to right over the scene, left of the panel (which starts 430 pixels from the right).
  // Pauses between the events: ImGui 1.86 reads the mouse's state once a frame, so a press,
  // move and release within one frame would not be a drag.
  ASSERT_TRUE(viewer.Send(
      "getwindowfocus mousemove --window %1 60 300 mousedown 1 sleep 0.3 "
      "mousemove --window %1 120 300 sleep 0.3 mousemove --window %1 180 300 sleep 0.3 mouseup 1"));
  const Image after = capture(++n);
  ASSERT_EQ(after.rgb.size(), before.rgb.size());
  int changed = 0;
  for (int y = 150; y < 480; ++y) {
    for (int x = 0; x < 200; ++x) changed += std::memcmp(before.At(x, y), after.At(x, y), 3) != 0;
  }
  EXPECT_GT(changed, 200 * 330 / 20);  // the scene turned

  ASSERT_TRUE(viewer.Send("getwindowfocus windowsize --sync %1 500 400"));
  const Image resized = capture(++n);
  EXPECT_EQ(resized.width, 500);
  EXPECT_EQ(resized.height, 400);
  EXPECT_EQ(viewer.Quit(), 0) << viewer.log();
}

}  // namespace
