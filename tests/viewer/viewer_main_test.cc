// Tests of viewer/main.cc: the real dysa-viewer binary on a private Xvfb display (Mesa's
// software OpenGL) against a real dysa-server. --screenshot renders a settled pool in both
// render modes; the PNG must have the asked size and show the fluid in the lower part of the box.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <stb/stb_image.h>

#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "support/server_process.h"
#include "support/temp_dir.h"
#include "support/xvfb_display.h"

#if !defined(DYSA_VIEWER_BINARY) || !defined(DYSA_SERVER_BINARY)
#error "tests/CMakeLists.txt defines DYSA_VIEWER_BINARY and DYSA_SERVER_BINARY"
#endif

namespace {

using dysa::testing::CommandResult;
using dysa::testing::RunCaptured;
using dysa::testing::ServerProcess;
using dysa::testing::XvfbDisplay;
using ::testing::HasSubstr;

// A pool at rest: a slab of fluid filling the bottom of the thesis's default domain
// ([-5, 5] x [-3, 3] x [-5, 5]), 3,456 particles, so the frame at t = 0 is already settled.
constexpr const char* kPoolScene = R"({
  "name": "pool",
  "fluid_blocks": [{"center": [0, -2, 0], "size": [9, 1.9, 9],
                    "particles_per_axis": [24, 6, 24], "jitter": 0}]
})";

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
                                        " LIBGL_ALWAYS_SOFTWARE=1 '" + DYSA_VIEWER_BINARY + "' " +
                                        args);
  }

  // Renders a screenshot in `mode` and checks what it shows.
  void CheckScreenshot(const std::string& mode) {
    const std::string png = (dir_.path() / (mode + ".png")).string();
    const CommandResult r = RunViewer("--server " + server_->address() + " --screenshot '" + png +
                                      "' --frames 3 --width " + std::to_string(kWidth) +
                                      " --height " + std::to_string(kHeight) + " --mode " + mode);
    ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
    EXPECT_THAT(r.out, HasSubstr("3456 particles"));
    const Image image = LoadPng(png);
    ASSERT_EQ(image.width, kWidth);
    ASSERT_EQ(image.height, kHeight);

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
  }

  XvfbDisplay display_{"1024x768x24"};
  dysa::testing::TempDir dir_{"dysa_viewer"};
  std::unique_ptr<ServerProcess> server_;
};

TEST_F(ViewerMainTest, ScreenshotShowsTheSettledPoolAsParticles) { CheckScreenshot("particles"); }

TEST_F(ViewerMainTest, ScreenshotShowsTheSettledPoolAsAFluidSurface) { CheckScreenshot("fluid"); }

TEST_F(ViewerMainTest, ScreenshotWithoutAServerFailsWithTheReason) {
  const CommandResult r = RunViewer("--server 127.0.0.1:1 --screenshot '" +
                                    (dir_.path() / "none.png").string() + "' --timeout 2");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("no particle frame from 127.0.0.1:1"));
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

}  // namespace
