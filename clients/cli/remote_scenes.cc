// dysa load, dysa scenes, dysa scene.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "remote_commands.h"
#include "remote_format.h"

namespace dysa::remote {
namespace {

namespace fs = std::filesystem;

// A vector as [x, y, z].
Json ToJson(const std::array<double, 3>& v) { return Json::array({v[0], v[1], v[2]}); }

// A moving obstacle's "motion" as a scene file writes a path: {"path": [[t, dx, dy, dz], ...]}
// (s, m). Static obstacles have no "motion".
void AddMotion(const ObstacleMotion& motion, Json& obstacle) {
  if (!motion.moving()) return;
  Json path = Json::array();
  for (const ObstacleMotion::Key& k : motion.keys) {
    path.push_back({k.time, k.displacement[0], k.displacement[1], k.displacement[2]});
  }
  obstacle["motion"] = {{"path", path}};
}

Json ToJson(const SceneDescription& s) {
  Json spheres = Json::array();
  for (const SphereObstacle& o : s.spheres) {
    Json sphere = {{"center", ToJson(o.center)}, {"radius", o.radius}};
    AddMotion(o.motion, sphere);
    spheres.push_back(std::move(sphere));
  }
  Json boxes = Json::array();
  for (const BoxObstacle& o : s.boxes) {
    Json box = {{"min", ToJson(o.min)}, {"max", ToJson(o.max)}};
    AddMotion(o.motion, box);
    boxes.push_back(std::move(box));
  }
  return {{"name", s.name},
          {"description", s.description},
          {"solver", s.solver},
          {"solvers", s.solvers},
          {"domain_min", ToJson(s.domain_min)},
          {"domain_max", ToJson(s.domain_max)},
          {"spheres", spheres},
          {"boxes", boxes},
          {"particle_radius", s.particle_radius},
          {"scene_version", s.scene_version}};
}

// "[-5, -3, 0.5]"
std::string Point(const std::array<double, 3>& v) {
  std::string text = "[";  // "[" + Short(...) draws a false -Wrestrict from GCC 12
  text += Short(v[0]) + ", " + Short(v[1]) + ", " + Short(v[2]) + "]";
  return text;
}

// ", moves: 2 keys, t 0-0.4 s, up to 0.6 m away" for a moving obstacle, "" for a static one.
std::string Moves(const ObstacleMotion& motion) {
  if (!motion.moving()) return "";
  // The path is linear between keys, so its farthest point is a key.
  double farthest = 0;
  for (const ObstacleMotion::Key& k : motion.keys) {
    const auto& d = k.displacement;
    farthest = std::max(farthest, std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]));
  }
  const size_t n = motion.keys.size();
  const std::string first = Short(motion.keys.front().time);
  const std::string last = Short(motion.keys.back().time);
  return ", moves: " + std::to_string(n) +
         (n == 1 ? " key, t " + first : " keys, t " + first + "-" + last) + " s, up to " +
         Short(farthest) + " m away";
}

}  // namespace

void LoadScene(Client& client, const std::string& scene, const std::string& solver, bool json,
               std::ostream& out) {
  std::error_code error;
  const fs::file_status status = fs::status(scene, error);
  // A file (or a pipe: `dysa load <(...)`) is sent as text; anything else is a built-in name.
  const bool is_file = fs::exists(status) && !fs::is_directory(status);
  if (fs::is_directory(status)) {
    throw std::runtime_error("'" + scene + "' is a directory, not a scene file");
  }
  // What can only be a path, the server would call an unknown name.
  const bool path_like = scene.find('/') != std::string::npos || scene.ends_with(".json");
  if (!is_file && path_like) throw std::runtime_error("no such file '" + scene + "'");
  ControlResult r;
  if (is_file) {
    std::ifstream file(scene, std::ios::binary);
    std::stringstream text;
    text << file.rdbuf();
    if (!file) throw std::runtime_error("cannot read " + scene);
    r = client.LoadSceneText(text.str(), solver);
  } else {
    try {
      r = client.LoadSceneByName(scene, solver);
    } catch (const RpcError& e) {
      // The server's "name: no built-in scene ..." speaks of the API's json_text.
      if (e.code_name() != "INVALID_ARGUMENT" || !e.message().starts_with("name:")) throw;
      throw std::runtime_error("'" + scene +
                               "' is neither a file here nor a built-in scene of the server "
                               "(dysa scenes lists them)");
    }
  }
  if (json) return PrintJson(ToJson(r), out);
  const ServerStatus& s = r.status;
  out << "loaded scene " << s.scene << (is_file ? " from " + scene : "") << ": " << s.particles
      << " particles, solver " << s.solver << ", " << s.state << " at " << Where(s) << "\n";
}

void PrintScenes(Client& client, bool json, std::ostream& out) {
  const SceneList list = client.ListScenes();
  if (json) {
    Json scenes = Json::array();
    for (const SceneInfo& s : list.scenes) {
      scenes.push_back({{"name", s.name},
                        {"description", s.description},
                        {"particles", s.particles},
                        {"solver", s.solver}});
    }
    return PrintJson({{"scenes", scenes}, {"current", list.current}}, out);
  }
  std::vector<std::vector<std::string>> rows = {{"  name", "particles", "solver", "description"}};
  for (const SceneInfo& s : list.scenes) {
    rows.push_back({(s.name == list.current ? "* " : "  ") + s.name, std::to_string(s.particles),
                    s.solver, s.description});
  }
  PrintTable(rows, {1}, out);
  bool listed = false;
  for (const SceneInfo& s : list.scenes) listed = listed || s.name == list.current;
  if (!listed && !list.current.empty()) {
    out << "current scene: " << list.current << " (loaded from a scene text)\n";
  }
}

void PrintScene(Client& client, bool json, std::ostream& out) {
  const SceneDescription s = client.GetScene();
  if (json) return PrintJson(ToJson(s), out);
  std::string solvers;
  for (const std::string& name : s.solvers) solvers += (solvers.empty() ? "" : ", ") + name;
  std::array<double, 3> size;
  for (int a = 0; a < 3; ++a) size[a] = s.domain_max[a] - s.domain_min[a];
  std::vector<std::vector<std::string>> rows = {
      {"scene", s.name},
      {"solver", s.solver + " (registered: " + solvers + ")"},
      {"domain", Point(s.domain_min) + " to " + Point(s.domain_max) + " m (" + Short(size[0]) +
                     " x " + Short(size[1]) + " x " + Short(size[2]) + " m)"},
      {"particle radius", Short(s.particle_radius) + " m"},
  };
  if (!s.description.empty()) rows.insert(rows.begin() + 1, {"description", s.description});
  for (const SphereObstacle& o : s.spheres) {
    rows.push_back({"sphere", "centre " + Point(o.center) + " m, radius " + Short(o.radius) + " m" +
                                  Moves(o.motion)});
  }
  for (const BoxObstacle& o : s.boxes) {
    rows.push_back({"box", Point(o.min) + " to " + Point(o.max) + " m" + Moves(o.motion)});
  }
  if (s.spheres.empty() && s.boxes.empty()) rows.push_back({"obstacles", "none"});
  rows.push_back({"version", std::to_string(s.scene_version)});
  PrintTable(rows, {}, out);
}

}  // namespace dysa::remote
