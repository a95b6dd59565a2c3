#include "control_panel.h"

#include <imgui.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

namespace dysa::viewer {

namespace {

std::string FormatBytes(double bytes) {
  char text[32];
  if (bytes >= 1e6) {
    std::snprintf(text, sizeof(text), "%.2f MB", bytes / 1e6);
  } else if (bytes >= 1e3) {
    std::snprintf(text, sizeof(text), "%.1f kB", bytes / 1e3);
  } else {
    std::snprintf(text, sizeof(text), "%.0f B", bytes);
  }
  return text;
}

// A slider's label: the parameter's name with underscores as spaces, its unit in brackets.
std::string SliderLabel(const remote::ParamInfo& p) {
  std::string label = p.name;
  std::replace(label.begin(), label.end(), '_', ' ');
  if (!p.unit.empty()) label += " [" + p.unit + "]";
  return label + "##" + p.name;
}

}  // namespace

bool ControlPanel::Draw(const ServerView& view, const remote::ReceiverStats& receiver,
                        const RenderStats& render, ServerLink& link, ViewerSettings& settings) {
  DrawOverlay(view, receiver, render, link);
  if (!settings.show_panel) return false;

  bool stream_changed = false;
  ImGui::SetNextWindowPos(ImVec2(ImGui::GetIO().DisplaySize.x - 430, 10), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(420, 680), ImGuiCond_FirstUseEver);
  if (ImGui::Begin("DySAQUASIMs")) {
    DrawControls(view, link);
    if (ImGui::CollapsingHeader("Scene and solver", ImGuiTreeNodeFlags_DefaultOpen)) {
      DrawScenePickers(view, link);
    }
    if (ImGui::CollapsingHeader("Parameters", ImGuiTreeNodeFlags_DefaultOpen))
      DrawParams(view, link);
    if (ImGui::CollapsingHeader("Rendering", ImGuiTreeNodeFlags_DefaultOpen)) {
      stream_changed = DrawRendering(settings);
    }
  }
  ImGui::End();
  return stream_changed;
}

void ControlPanel::DrawControls(const ServerView& view, ServerLink& link) {
  ImGui::BeginDisabled(!view.connected);
  const bool running = view.status.state == "running";
  if (ImGui::Button(running ? "Pause (Space)" : "Resume (Space)", ImVec2(120, 0))) {
    running ? link.Pause() : link.Resume();
  }
  ImGui::SameLine();
  if (ImGui::Button("Reset (R)")) link.Reset();
  if (ImGui::Button("< Back")) link.StepBack(uint32_t(step_frames_));
  ImGui::SameLine();
  if (ImGui::Button("Step >")) link.Step(uint32_t(step_frames_));
  ImGui::SameLine();
  ImGui::SetNextItemWidth(90);
  ImGui::InputInt("frames", &step_frames_);
  step_frames_ = std::clamp(step_frames_, 1, 10000);  // the server's StepRequest limit
  ImGui::EndDisabled();
}

void ControlPanel::DrawScenePickers(const ServerView& view, ServerLink& link) {
  if (!view.scene) {
    ImGui::TextDisabled("waiting for the server");
    return;
  }
  const remote::SceneDescription& scene = *view.scene;
  ImGui::BeginDisabled(!view.connected);
  if (ImGui::BeginCombo("scene", scene.name.c_str())) {
    for (const remote::SceneInfo& info : view.scenes) {
      char label[160];
      std::snprintf(label, sizeof(label), "%s (%u particles)", info.name.c_str(), info.particles);
      if (ImGui::Selectable(label, info.name == scene.name)) link.LoadScene(info.name);
      if (ImGui::IsItemHovered() && !info.description.empty()) {
        ImGui::SetTooltip("%s", info.description.c_str());
      }
    }
    ImGui::EndCombo();
  }
  if (ImGui::BeginCombo("solver", scene.solver.c_str())) {
    for (const std::string& solver : scene.solvers) {
      // Switching solvers reloads the scene with the other solver (its parameters differ).
      if (ImGui::Selectable(solver.c_str(), solver == scene.solver) && solver != scene.solver) {
        link.LoadScene(scene.name, solver);
      }
    }
    ImGui::EndCombo();
  }
  ImGui::EndDisabled();
}

void ControlPanel::DrawParams(const ServerView& view, ServerLink& link) {
  if (view.params.empty()) {
    ImGui::TextDisabled("waiting for the server");
    return;
  }
  if (view.params_revision != editing_revision_ && !ImGui::IsAnyItemActive()) {
    editing_.clear();  // the server answered: show its values again
    editing_revision_ = view.params_revision;
  }
  // Only the running solver's parameters (and those every solver reads): the others would
  // change nothing it does.
  const std::string& solver = view.status.solver;
  if (!solver.empty()) ImGui::TextDisabled("the %s solver's parameters", solver.c_str());
  ImGui::BeginDisabled(!view.connected);
  ImGui::PushItemWidth(170);
  for (const remote::ParamInfo& p : view.params) {
    if (!p.ReadBy(solver)) continue;
    auto it = editing_.find(p.name);
    double value = it != editing_.end() ? it->second : p.value;
    const std::string label = SliderLabel(p);
    bool changed;
    if (p.integer) {
      int v = int(std::lround(value));
      changed = ImGui::SliderInt(label.c_str(), &v, int(p.min), int(p.max), "%d",
                                 ImGuiSliderFlags_AlwaysClamp);
      value = v;
    } else {
      // Ranges over several decades (viscosity, pressure multipliers) get a logarithmic slider,
      // so small values stay reachable.
      const bool wide = p.min >= 0 && p.max > 1000 * std::max(std::abs(p.default_value), 1e-9);
      const ImGuiSliderFlags flags =
          ImGuiSliderFlags_AlwaysClamp | (wide ? ImGuiSliderFlags_Logarithmic : 0);
      changed = ImGui::SliderScalar(label.c_str(), ImGuiDataType_Double, &value, &p.min, &p.max,
                                    "%.4g", flags);
    }
    if (changed) editing_[p.name] = value;
    // Sent once the user lets go, so a drag is one change (and at most one reset).
    if (ImGui::IsItemDeactivatedAfterEdit()) link.SetParam(p.name, editing_[p.name]);
    if (ImGui::IsItemHovered()) {
      ImGui::SetTooltip("%s\nrange [%g, %g] %s, default %g%s", p.description.c_str(), p.min, p.max,
                        p.unit.c_str(), p.default_value,
                        p.needs_reset ? "\nchanging it resets the simulation" : "");
    }
  }
  ImGui::PopItemWidth();
  ImGui::EndDisabled();
}

bool ControlPanel::DrawRendering(ViewerSettings& settings) {
  int mode = settings.mode == RenderMode::kFluidSurface ? 1 : 0;
  ImGui::RadioButton("particles", &mode, 0);
  ImGui::SameLine();
  ImGui::RadioButton("fluid surface", &mode, 1);
  settings.mode = mode == 1 ? RenderMode::kFluidSurface : RenderMode::kParticles;

  SceneStyle& style = settings.style;
  ImGui::PushItemWidth(170);
  ImGui::DragFloatRange2("speed colours [m/s]", &style.speed_lo, &style.speed_hi, 0.05f, 0.0f,
                         100.0f, "%.2f", "%.2f", ImGuiSliderFlags_AlwaysClamp);
  if (style.speed_hi <= style.speed_lo) style.speed_hi = style.speed_lo + 0.01f;
  ImGui::SliderFloat("particle size", &style.particle_scale, 0.2f, 3.0f, "%.2f x");
  ImGui::Checkbox("domain box", &style.draw_box);
  ImGui::SameLine();
  ImGui::Checkbox("obstacles", &style.draw_obstacles);
  if (settings.mode == RenderMode::kFluidSurface) {
    ImGui::SliderFloat("surface radius", &settings.fluid_radius_scale, 1.0f, 4.0f, "%.1f x");
    ImGui::SliderFloat("smoothing [particles]", &settings.fluid.filter_radius_particles, 1.0f, 6.0f,
                       "%.1f");
    ImGui::SliderFloat("smoothing cap [px]", &settings.fluid.filter_radius_pixels, 1.0f, 32.0f,
                       "%.0f");
    ImGui::SliderInt("smoothing passes", &settings.fluid.smoothing_iterations, 0, 6);
  }

  bool stream_changed = false;
  int stride = int(std::max<uint32_t>(settings.stream.stride, 1));
  if (ImGui::SliderInt("level of detail", &stride, 1, 16, "every %d.",
                       ImGuiSliderFlags_AlwaysClamp)) {
    settings.stream.stride = uint32_t(stride);
  }
  stream_changed |= ImGui::IsItemDeactivatedAfterEdit();
  float max_fps = float(settings.stream.max_fps);
  if (ImGui::SliderFloat("frame cap [1/s]", &max_fps, 0.0f, 120.0f, max_fps > 0 ? "%.0f" : "off")) {
    settings.stream.max_fps = max_fps;
  }
  stream_changed |= ImGui::IsItemDeactivatedAfterEdit();
  ImGui::PopItemWidth();
  return stream_changed;
}

void ControlPanel::DrawOverlay(const ServerView& view, const remote::ReceiverStats& receiver,
                               const RenderStats& render, ServerLink& link) {
  ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_Always);
  ImGui::SetNextWindowBgAlpha(0.55f);
  const ImGuiWindowFlags flags = ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_AlwaysAutoResize |
                                 ImGuiWindowFlags_NoSavedSettings |
                                 ImGuiWindowFlags_NoFocusOnAppearing | ImGuiWindowFlags_NoNav;
  if (ImGui::Begin("status", nullptr, flags)) {
    if (view.connected) {
      ImGui::Text("%s  %s  %s", render.address.c_str(), view.status.state.c_str(),
                  view.status.solver.c_str());
    } else {
      ImGui::TextColored(ImVec4(1, 0.6f, 0.3f, 1), "%s: not connected", render.address.c_str());
      if (!view.connection_error.empty()) ImGui::TextWrapped("%s", view.connection_error.c_str());
    }
    ImGui::Text("render %.0f fps   simulation %.1f frames/s", render.render_fps,
                view.status.frames_per_second);
    ImGui::Text("t = %.3f s   frame %llu   %u particles (%u drawn)", view.status.time,
                static_cast<unsigned long long>(view.status.frame), view.status.particles,
                render.particles_drawn);
    if (render.detail < 1) {
      ImGui::Text("detail %.3f (budget)   radius x %.2f", render.detail, render.detail_scale);
    }
    ImGui::Text("stream %.0f frames/s   %s/frame   latency %.1f ms", receiver.frames_per_second,
                FormatBytes(receiver.bytes_per_frame).c_str(), receiver.latency_ms);
    if (!receiver.streaming && !receiver.error.empty()) {
      ImGui::TextColored(ImVec4(1, 0.6f, 0.3f, 1), "stream: %s", receiver.error.c_str());
    }
    if (!view.status.alarm.empty()) {
      ImGui::TextColored(ImVec4(1, 0.3f, 0.3f, 1), "ALARM: %s", view.status.alarm.c_str());
    }
    if (!view.status.warning.empty()) {
      ImGui::TextColored(ImVec4(1, 0.75f, 0.3f, 1), "warning: %s", view.status.warning.c_str());
    }
    for (const UserMessage& m : view.messages) {
      ImGui::TextColored(m.error ? ImVec4(1, 0.35f, 0.35f, 1) : ImVec4(0.7f, 0.85f, 1, 1), "%s",
                         m.text.c_str());
    }
    if (!view.messages.empty() && ImGui::SmallButton("dismiss")) link.DismissMessages();
  }
  ImGui::End();
}

}  // namespace dysa::viewer
