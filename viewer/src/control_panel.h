// The Dear ImGui control panel and status overlay. Every slider's range, unit and default come
// from the server's GetParams (the core's parameter table); nothing here lists parameters.
#pragma once

#include <map>
#include <string>

#include "dysa/client/frame_receiver.h"
#include "dysa/client/types.h"
#include "fluid_renderer.h"
#include "scene_renderer.h"
#include "server_link.h"

namespace dysa::viewer {

enum class RenderMode { kParticles, kFluidSurface };

// What the user chose in the panel (not the server's state).
struct ViewerSettings {
  RenderMode mode = RenderMode::kParticles;
  SceneStyle style;
  FluidStyle fluid;
  float fluid_radius_scale = 2.0f;  // the surface's particle radius over the drawn radius
  remote::StreamOptions stream;     // fields, frame-rate cap, stride
  bool show_panel = true;
};

// Numbers the overlay shows that the panel does not get from the server.
struct RenderStats {
  double render_fps = 0;
  uint32_t particles_drawn = 0;
  double detail = 1;       // fraction of the particles the latest frame holds
  float detail_scale = 1;  // their drawn radius over the full set's
  std::string address;
};

class ControlPanel {
 public:
  // Draws the panel and overlay for this frame; user actions go to `link`. Returns true when
  // the stream options changed (the caller restarts the stream).
  bool Draw(const ServerView& view, const remote::ReceiverStats& receiver,
            const RenderStats& render, ServerLink& link, ViewerSettings& settings);

 private:
  void DrawControls(const ServerView& view, ServerLink& link);
  void DrawScenePickers(const ServerView& view, ServerLink& link);
  void DrawParams(const ServerView& view, ServerLink& link);
  bool DrawRendering(ViewerSettings& settings);
  void DrawOverlay(const ServerView& view, const remote::ReceiverStats& receiver,
                   const RenderStats& render, ServerLink& link);

  // Values being edited, by parameter name: shown instead of the server's value from the first
  // drag until the server's reply to the change arrives (params_revision moves on).
  std::map<std::string, double> editing_;
  uint64_t editing_revision_ = 0;
  int step_frames_ = 1;
};

}  // namespace dysa::viewer
