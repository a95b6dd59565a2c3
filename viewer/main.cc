// dysa-viewer: watches and steers a dysa-server. Phases, as in Dear ImGui's GLFW + OpenGL3
// example: options, window, ImGui, renderers, network, the loop, then cleanup in reverse.
// GLFW must not pull in the legacy GL/gl.h: the core profile's declarations come from gl.h.
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "backends/imgui_impl_glfw.h"
#include "backends/imgui_impl_opengl3.h"
#include "dysa/client/frame_receiver.h"
#include "src/control_panel.h"
#include "src/fluid_renderer.h"
#include "src/gl.h"
#include "src/orbit_camera.h"
#include "src/render_target.h"
#include "src/scene_renderer.h"
#include "src/server_link.h"
#include "src/session_watch.h"
#include "src/stream_camera.h"

namespace {

using Clock = std::chrono::steady_clock;
using namespace dysa::viewer;

struct Options {
  dysa::remote::ConnectOptions connect;
  std::string screenshot;         // PNG path; empty: interactive
  int frames = 30;                // rendered frames before the screenshot
  double timeout = 60;            // s: --screenshot gives up unless written by then
  double server_timeout = 5;      // s without the server, once connected, before exiting
  bool screenshot_panel = false;  // the control panel and overlay in the screenshot too
  std::string capture_dir = ".";  // where F12 saves dysa-viewer-N.png
  int width = 1280;
  int height = 800;
  std::string mode = "particles";
  uint32_t stride = 1;
  double max_fps = 0;
  double fps_target = 0;
  uint64_t byte_budget = 0;
  uint32_t particle_budget = 0;
  bool vsync = true;
};

// Returns 0 to go on, or the exit status for CLI11's error or help.
int ParseOptions(int argc, char** argv, Options& options) {
  CLI::App app{"dysa-viewer: watch and steer a dysa-server"};
  if (const char* env = std::getenv("DYSA_SERVER")) options.connect.address = env;
  if (const char* env = std::getenv("DYSA_TOKEN")) options.connect.token = env;
  app.add_option("--server", options.connect.address, "Server address host:port (env DYSA_SERVER)")
      ->capture_default_str();
  app.add_option("--token", options.connect.token, "Bearer token for control (env DYSA_TOKEN)");
  app.add_option("--tls-ca", options.connect.tls_ca_file, "PEM roots: connect over TLS")
      ->check(CLI::ExistingFile);
  app.add_option("--tls-name", options.connect.tls_server_name,
                 "Name on the server's certificate, when it differs from the host");
  app.add_option("--screenshot", options.screenshot,
                 "Render --frames frames once particles arrive, write this PNG and exit");
  app.add_option("--frames", options.frames, "Frames to render before --screenshot")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  app.add_option("--capture-dir", options.capture_dir,
                 "Folder where F12 saves the view as dysa-viewer-N.png")
      ->check(CLI::ExistingDirectory)
      ->capture_default_str();
  app.add_flag("--screenshot-panel", options.screenshot_panel,
               "Include the control panel and status overlay in the screenshot");
  app.add_option("--timeout", options.timeout,
                 "Seconds --screenshot may take before it gives up (exit status 1)")
      ->check(CLI::Range(1.0, 3600.0))
      ->capture_default_str();
  app.add_option("--server-timeout", options.server_timeout,
                 "Seconds without the server, once connected, before exiting (0: wait for it)")
      ->check(CLI::Range(0.0, 86400.0))
      ->capture_default_str();
  app.add_option("--width", options.width, "Window width, pixels")
      ->check(CLI::Range(64, 8192))
      ->capture_default_str();
  app.add_option("--height", options.height, "Window height, pixels")
      ->check(CLI::Range(64, 8192))
      ->capture_default_str();
  app.add_option("--mode", options.mode, "Rendering: particles or fluid (screen-space surface)")
      ->check(CLI::IsMember({"particles", "fluid"}))
      ->capture_default_str();
  app.add_option("--stride", options.stride, "Level of detail: every Nth particle")
      ->check(CLI::Range(1u, 1000000u))
      ->capture_default_str();
  app.add_option("--max-fps", options.max_fps, "Frames per second to ask the server for (0: all)")
      ->check(CLI::Range(0.0, 1000.0))
      ->capture_default_str();
  app.add_option("--fps-target", options.fps_target,
                 "Frames per second to hold on this link: the server sends a stable, even subset "
                 "of the particles that fits, drawn larger (docs/viewer.md)")
      ->check(CLI::Range(0.001, 1000.0));
  app.add_option("--byte-budget", options.byte_budget,
                 "With --fps-target: at most B bytes per second (>= 1000)")
      ->check(CLI::Range(uint64_t{1000}, uint64_t{1} << 50));
  app.add_option("--particle-budget", options.particle_budget, "At most P particles per frame")
      ->check(CLI::Range(1u, 20000000u));
  app.add_flag("!--no-vsync", options.vsync, "Render as fast as possible (benchmarks)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int status = app.exit(e);
    return status == 0 ? -1 : status;  // -1: help printed, exit 0
  }
  if (options.byte_budget > 0 && options.fps_target == 0) {
    std::fprintf(stderr,
                 "dysa-viewer: error: --byte-budget: needs --fps-target (bytes per second are "
                 "spread over the target frame rate)\n");
    return 2;
  }
  return 0;
}

// SIGINT/SIGTERM end the loop like closing the window: the threads stop and GL is torn down.
volatile std::sig_atomic_t quit_requested = 0;
void RequestQuit(int) { quit_requested = 1; }

void GlfwError(int code, const char* text) {
  std::fprintf(stderr, "dysa-viewer: GLFW error %d: %s\n", code, text);
}

// Key presses since the last frame, in order. Queued by a GLFW callback rather than read from
// ImGui's key state: a press and its release within one frame (a quick tap, or a scripted
// `xdotool key`) would otherwise never be seen as down by ImGui 1.86.
struct KeyQueue {
  std::vector<int> keys;
};

void QueueKey(GLFWwindow* window, int key, int /*scancode*/, int action, int /*mods*/) {
  auto* queue = static_cast<KeyQueue*>(glfwGetWindowUserPointer(window));
  const bool repeats = key == GLFW_KEY_LEFT || key == GLFW_KEY_RIGHT;  // held: keep stepping
  if (queue != nullptr && (action == GLFW_PRESS || (repeats && action == GLFW_REPEAT))) {
    queue->keys.push_back(key);
  }
}

// Mouse and keys go to the camera and server unless ImGui wants them (a slider being dragged,
// a text field with the focus). Returns true when F12 asked for a capture of the view.
bool HandleInput(OrbitCamera& camera, ServerLink& link, KeyQueue& queue, int framebuffer_height) {
  bool capture = false;
  const ImGuiIO& io = ImGui::GetIO();
  if (!io.WantCaptureMouse) {
    if (ImGui::IsMouseDragging(ImGuiMouseButton_Left)) {
      camera.Orbit(io.MouseDelta.x, io.MouseDelta.y);
    }
    if (ImGui::IsMouseDragging(ImGuiMouseButton_Right) ||
        ImGui::IsMouseDragging(ImGuiMouseButton_Middle)) {
      // Mouse deltas are in window coordinates; pan wants the window's height in the same.
      camera.Pan(io.MouseDelta.x, io.MouseDelta.y,
                 io.DisplaySize.y > 0 ? io.DisplaySize.y : float(framebuffer_height));
    }
    if (io.MouseWheel != 0) camera.Zoom(io.MouseWheel);
  }
  if (!io.WantCaptureKeyboard) {
    for (int key : queue.keys) {
      switch (key) {
        case GLFW_KEY_SPACE:
          link.TogglePause();
          break;
        case GLFW_KEY_RIGHT:
          link.Step(1);
          break;
        case GLFW_KEY_LEFT:
          link.StepBack(1);
          break;
        case GLFW_KEY_R:
          link.Reset();
          break;
        case GLFW_KEY_F12:
          capture = true;
          break;
        default:
          break;
      }
    }
  }
  queue.keys.clear();
  return capture;
}

int Run(const Options& options) {
  std::signal(SIGINT, RequestQuit);
  std::signal(SIGTERM, RequestQuit);

  // Window and OpenGL 3.3 core context.
  glfwSetErrorCallback(GlfwError);
  if (!glfwInit()) {
    std::fprintf(stderr, "dysa-viewer: cannot initialise GLFW (no display? set DISPLAY)\n");
    return 1;
  }
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  GLFWwindow* window =
      glfwCreateWindow(options.width, options.height, "DySAQUASIMs viewer", nullptr, nullptr);
  if (window == nullptr) {
    std::fprintf(stderr, "dysa-viewer: cannot create an OpenGL 3.3 core window\n");
    glfwTerminate();
    return 1;
  }
  glfwMakeContextCurrent(window);
  glfwSwapInterval(options.vsync && options.screenshot.empty() ? 1 : 0);

  // Dear ImGui.
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini in the working directory
  ImGui::StyleColorsDark();
  // Our key callback first: ImGui's back end chains to the callback it finds installed.
  KeyQueue key_queue;
  glfwSetWindowUserPointer(window, &key_queue);
  glfwSetKeyCallback(window, QueueKey);
  ImGui_ImplGlfw_InitForOpenGL(window, true);
  ImGui_ImplOpenGL3_Init("#version 330 core");

  int status = 0;
  try {
    // Renderers.
    SceneRenderer scene_renderer;
    FluidRenderer fluid_renderer;
    RenderTarget scene_target;
    OrbitCamera camera;

    // Network: controls and status on one thread, frames on another.
    ViewerSettings settings;
    settings.mode = options.mode == "fluid" ? RenderMode::kFluidSurface : RenderMode::kParticles;
    settings.stream.stride = options.stride;
    settings.stream.max_fps = options.max_fps;
    settings.stream.fps_target = options.fps_target;
    settings.stream.byte_budget = options.byte_budget;
    settings.stream.particle_budget = options.particle_budget;
    const bool screenshot = !options.screenshot.empty();
    settings.show_panel = !screenshot || options.screenshot_panel;
    // A screenshot shows what the server sends, not where the pointer happens to hover.
    if (screenshot) ImGui::GetIO().ConfigFlags |= ImGuiConfigFlags_NoMouse;
    ServerLink link(options.connect);
    dysa::remote::FrameReceiver receiver(options.connect, settings.stream);
    link.Start();
    receiver.Start();

    ControlPanel panel;
    dysa::remote::ReceivedFrame frame;
    uint64_t scene_revision = 0;
    std::string fitted_scene;
    int captures = 0;                        // F12 presses saved
    dysa::remote::StreamCamera last_camera;  // the camera last given to the stream
    bool have_particles = false;
    int frames_after_particles = 0;
    RenderStats render_stats;
    render_stats.address = options.connect.address;
    int frames_this_second = 0;
    Clock::time_point second_start = Clock::now();
    const Clock::time_point start = second_start;
    Clock::time_point first_particles;
    // A viewer left behind exits by itself: the server gone, or a screenshot's parent or time.
    const pid_t parent = screenshot ? WatchParent() : getppid();
    SessionWatch watch({screenshot, options.server_timeout, options.timeout}, parent, start);
    bool written = false;

    // The loop.
    while (!glfwWindowShouldClose(window) && quit_requested == 0) {
      glfwPollEvents();
      const ServerView view = link.View();
      const dysa::remote::ReceiverStats receiver_stats = receiver.Stats();

      if (view.scene && view.scene_revision != scene_revision) {
        scene_renderer.SetScene(*view.scene);
        // A new scene gets a fitted view; the same scene re-spawned keeps the user's camera.
        if (view.scene->name != fitted_scene) {
          const auto& lo = view.scene->domain_min;
          const auto& hi = view.scene->domain_max;
          camera.FitBox(Eigen::Vector3f(float(lo[0]), float(lo[1]), float(lo[2])),
                        Eigen::Vector3f(float(hi[0]), float(hi[1]), float(hi[2])));
          fitted_scene = view.scene->name;
        }
        scene_revision = view.scene_revision;
      }
      if (receiver.TakeLatest(frame)) {
        scene_renderer.UploadParticles(frame.frame);
        render_stats.particles_drawn = frame.frame.count;
        render_stats.detail = scene_renderer.detail();
        render_stats.detail_scale = scene_renderer.detail_scale();
        if (!have_particles) first_particles = Clock::now();
        have_particles = true;
      }

      ImGui_ImplOpenGL3_NewFrame();
      ImGui_ImplGlfw_NewFrame();
      ImGui::NewFrame();
      int width = 0;
      int height = 0;
      glfwGetFramebufferSize(window, &width, &height);
      const bool capture = !screenshot && HandleInput(camera, link, key_queue, height);
      if (panel.Draw(view, receiver_stats, render_stats, link, settings)) {
        receiver.SetStreamOptions(settings.stream);
      }
      ImGui::Render();

      // A budgeted stream spends its particles on what this camera sees (docs/viewer.md).
      const bool budgeted = settings.stream.fps_target > 0 || settings.stream.particle_budget > 0;
      if (budgeted && width > 0 && height > 0) {
        const dysa::remote::StreamCamera sent = ToStreamCamera(camera, float(width) / height);
        if (sent != last_camera) receiver.SetCamera(sent);
        last_camera = sent;
      }

      if (width > 0 && height > 0) {  // 0 while minimised
        ViewParams view_params{camera.View(),
                               camera.Projection(float(width) / float(height)),
                               width,
                               height,
                               camera.near_plane(),
                               camera.far_plane()};
        scene_target.Resize(width, height);
        scene_target.Bind();
        scene_renderer.DrawEnvironment(view_params, settings.style);
        if (settings.mode == RenderMode::kParticles) {
          scene_renderer.DrawParticles(view_params, settings.style);
          scene_target.BlitTo(0);
        } else {
          ParticleBuffer particles = scene_renderer.Particles(settings.style);
          particles.radius *= settings.fluid_radius_scale;
          fluid_renderer.Render(view_params, particles, scene_target.color(), scene_target.depth(),
                                0, settings.fluid);
        }
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
        glViewport(0, 0, width, height);
        if (screenshot && have_particles && scene_revision > 0 &&
            ++frames_after_particles >= options.frames) {
          // The scene alone, unless the panel was asked for too.
          if (options.screenshot_panel) ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
          WritePng(options.screenshot, ReadWindowPixels(width, height), width, height);
          written = true;
          const double seconds =
              std::chrono::duration<double>(Clock::now() - first_particles).count();
          std::printf(
              "dysa-viewer: wrote %s (%dx%d, %s, %u particles): %d frames in %.3f s, %.1f "
              "frames/s\n",
              options.screenshot.c_str(), width, height, options.mode.c_str(),
              render_stats.particles_drawn, options.frames, seconds,
              seconds > 0 ? options.frames / seconds : 0.0);
          break;
        }
        if (capture) {  // F12: the view as it is now, without the panel
          const std::string path =
              options.capture_dir + "/dysa-viewer-" + std::to_string(++captures) + ".png";
          try {
            WritePng(path, ReadWindowPixels(width, height), width, height);
            std::printf("dysa-viewer: saved %s (%dx%d)\n", path.c_str(), width, height);
          } catch (const std::exception& e) {
            std::fprintf(stderr, "dysa-viewer: %s\n", e.what());
          }
          std::fflush(stdout);
        }
        ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
      }
      glfwSwapBuffers(window);

      ++frames_this_second;
      const Clock::time_point now = Clock::now();
      if (now - second_start >= std::chrono::milliseconds(500)) {
        render_stats.render_fps =
            frames_this_second / std::chrono::duration<double>(now - second_start).count();
        frames_this_second = 0;
        second_start = now;
      }
      std::string waiting_for;
      if (screenshot && !have_particles) {
        waiting_for = "particle frame";
      } else if (screenshot && scene_revision == 0) {
        waiting_for = "scene description";
      }
      const std::string connection_error =
          view.connected ? receiver_stats.error : view.connection_error;
      if (const auto why =
              watch.Check(now, view.connected, connection_error, waiting_for, getppid())) {
        std::fprintf(stderr, "dysa-viewer: exiting: %s (server %s)\n", why->c_str(),
                     options.connect.address.c_str());
        status = 1;
        break;
      }
      // Nothing to show yet: a screenshot run (no vsync) would otherwise spin a core.
      if (screenshot && !waiting_for.empty()) {
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
    }
    if (screenshot && !written && status == 0) {
      std::fprintf(stderr, "dysa-viewer: stopped before the screenshot was written\n");
      status = 1;
    }

    // Cleanup of the network before the GL objects (destructors, in reverse order).
    receiver.Stop();
    link.Stop();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dysa-viewer: %s\n", e.what());
    status = 1;
  }

  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  glfwDestroyWindow(window);
  glfwTerminate();
  return status;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  if (const int status = ParseOptions(argc, argv, options); status != 0) {
    return status == -1 ? 0 : status;
  }
  return Run(options);
}
