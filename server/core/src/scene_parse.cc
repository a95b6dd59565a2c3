// Scene files: the JSON document read into a Scene, every field checked against its kind and
// range, and every failure a ConfigError that names the field's path (scene.h, ParseScene).
#include <cmath>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "dysa/core/scene.h"
#include "dysa/core/solver.h"
#include "dysa/core/text.h"
#include "scene_json.h"

namespace dysa {
namespace {

using nlohmann::json;

std::string Num(double v) { return ExactNumber(v); }

// Client text quoted in a message: escaped and bounded (SafeText).
std::string Quoted(std::string_view text) { return "\"" + SafeText(text) + "\""; }

// A name or description the scene keeps and every status reply and log line may show: at most
// `max_bytes` long and without control characters (but for newlines and tabs, when
// `multiline`), so that replies stay far below gRPC's message limit and a name cannot forge log
// lines or drive a terminal.
void CheckKeptText(const std::string& text, const std::string& path, size_t max_bytes,
                   bool multiline) {
  if (text.size() > max_bytes) {
    throw ConfigError(path, "at most " + std::to_string(max_bytes) + " bytes; got " +
                                std::to_string(text.size()));
  }
  std::string checked = text;
  if (multiline) std::erase_if(checked, [](char c) { return c == '\n' || c == '\t'; });
  if (HasUnsafeCharacters(checked)) {
    throw ConfigError(path, std::string("control characters ") +
                                (multiline ? "other than newlines and tabs " : "") +
                                "are not allowed; got " + Quoted(text));
  }
}

std::string TypeName(const json& j) { return j.type_name(); }

// Reads the fields of one JSON object, each under its full path ("fluid_blocks[0].size"), and
// rejects any field it was not asked for.
class ObjectReader {
 public:
  ObjectReader(const json& object, std::string path) : object_(object), path_(std::move(path)) {
    if (!object_.is_object()) {
      throw ConfigError(path_, "expected an object, got " + TypeName(object_));
    }
  }

  std::string PathOf(std::string_view key) const {
    return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
  }

  const json* Get(std::string_view key) {
    known_.insert(std::string(key));
    auto it = object_.find(key);
    return it == object_.end() ? nullptr : &*it;
  }

  std::optional<double> Number(std::string_view key, double min, double max,
                               std::string_view unit = "") {
    const json* j = Get(key);
    if (j == nullptr) return std::nullopt;
    return CheckNumber(*j, PathOf(key), min, max, unit);
  }

  std::optional<int64_t> Integer(std::string_view key, int64_t min, int64_t max) {
    const json* j = Get(key);
    if (j == nullptr) return std::nullopt;
    return CheckInteger(*j, PathOf(key), min, max);
  }

  std::optional<std::string> String(std::string_view key) {
    const json* j = Get(key);
    if (j == nullptr) return std::nullopt;
    if (!j->is_string()) throw ConfigError(PathOf(key), "expected a string, got " + TypeName(*j));
    return j->get<std::string>();
  }

  // [x, y, z]; with allow_scalar a single number means the same value on every axis.
  std::optional<Vec3d> Vector(std::string_view key, double min, double max,
                              std::string_view unit = "", bool allow_scalar = false) {
    const json* j = Get(key);
    if (j == nullptr) return std::nullopt;
    const std::string path = PathOf(key);
    if (allow_scalar && j->is_number()) {
      return Vec3d::Constant(CheckNumber(*j, path, min, max, unit));
    }
    if (!j->is_array() || j->size() != 3) {
      throw ConfigError(
          path, std::string("expected an array of 3 numbers") +
                    (allow_scalar ? " or a number" : "") + ", got " +
                    (j->is_array() ? "an array of " + std::to_string(j->size()) : TypeName(*j)));
    }
    Vec3d v;
    for (int a = 0; a < 3; ++a) {
      v[a] = CheckNumber((*j)[a], path + "[" + std::to_string(a) + "]", min, max, unit);
    }
    return v;
  }

  // Call once every field has been read: any other field is an error.
  void RejectUnknown() const {
    for (const auto& [key, value] : object_.items()) {
      if (known_.count(key) != 0) continue;
      std::string allowed;
      for (const std::string& k : known_) allowed += (allowed.empty() ? "" : ", ") + k;
      throw ConfigError(PathOf(SafeText(key)), "unknown field; allowed fields here: " + allowed);
    }
  }

  static double CheckNumber(const json& j, const std::string& path, double min, double max,
                            std::string_view unit = "") {
    const std::string range =
        "[" + Num(min) + ", " + Num(max) + "]" + (unit.empty() ? "" : " " + std::string(unit));
    if (!j.is_number()) {
      throw ConfigError(path, "expected a number in " + range + ", got " + TypeName(j));
    }
    const double v = j.get<double>();
    if (!(v >= min && v <= max)) {
      throw ConfigError(path, Num(v) + " is outside the allowed range " + range);
    }
    return v;
  }

  static int64_t CheckInteger(const json& j, const std::string& path, int64_t min, int64_t max) {
    const std::string range = "[" + std::to_string(min) + ", " + std::to_string(max) + "]";
    if (!j.is_number() || (j.is_number_float() && j.get<double>() != std::floor(j.get<double>()))) {
      throw ConfigError(path, "expected an integer in " + range + ", got " +
                                  (j.is_number() ? Num(j.get<double>()) : TypeName(j)));
    }
    const double v = j.get<double>();
    if (!(v >= double(min) && v <= double(max))) {
      throw ConfigError(path, Num(v) + " is outside the allowed range " + range);
    }
    return static_cast<int64_t>(v);
  }

 private:
  const json& object_;
  std::string path_;
  std::set<std::string> known_;
};

// Generous bounds that keep arithmetic finite; physical sense is the solver's business.
constexpr double kMaxCoord = 1e6;  // m
constexpr double kMaxSpeed = 1e4;  // m/s
constexpr int64_t kMaxPerAxis = 100'000;

// Iterates a JSON array field, calling parse(element, "key[i]") for each element.
template <class F>
void ForEachElement(ObjectReader& reader, std::string_view key, F&& parse) {
  const json* array = reader.Get(key);
  if (array == nullptr) return;
  if (!array->is_array()) {
    throw ConfigError(reader.PathOf(key), "expected an array, got " + TypeName(*array));
  }
  for (size_t i = 0; i < array->size(); ++i) {
    parse((*array)[i], reader.PathOf(key) + "[" + std::to_string(i) + "]");
  }
}

// An optional array of 3 booleans, one per axis.
void ParseAxisFlags(ObjectReader& r, std::string_view key, std::array<bool, 3>& flags) {
  const json* j = r.Get(key);
  if (j == nullptr) return;
  const std::string p = r.PathOf(key);
  if (!j->is_array() || j->size() != 3) {
    throw ConfigError(p, "expected an array of 3 booleans (x, y, z)");
  }
  for (int a = 0; a < 3; ++a) {
    if (!(*j)[a].is_boolean()) {
      throw ConfigError(p + "[" + std::to_string(a) + "]",
                        "expected true or false, got " + TypeName((*j)[a]));
    }
    flags[a] = (*j)[a].get<bool>();
  }
}

// A box; the domain's also reads which axes wrap around and which walls hold the fluid.
Aabb ParseBox(const json& j, const std::string& path, Scene* domain_of = nullptr) {
  ObjectReader r(j, path);
  Aabb box;
  for (const char* key : {"min", "max"}) {
    const std::optional<Vec3d> corner = r.Vector(key, -kMaxCoord, kMaxCoord, "m");
    if (!corner) throw ConfigError(r.PathOf(key), "is required");
    (key[1] == 'i' ? box.min : box.max) = *corner;
  }
  if (domain_of != nullptr) {
    ParseAxisFlags(r, "periodic", domain_of->periodic);
    ParseAxisFlags(r, "no_slip", domain_of->no_slip);
    for (int a = 0; a < 3; ++a) {
      if (domain_of->periodic[a] && domain_of->no_slip[a]) {
        throw ConfigError(r.PathOf("no_slip") + "[" + std::to_string(a) + "]",
                          "a periodic axis has no walls to be no-slip");
      }
    }
  }
  r.RejectUnknown();
  for (int a = 0; a < 3; ++a) {
    if (!(box.max[a] > box.min[a])) {
      throw ConfigError(r.PathOf("max"), "must exceed " + r.PathOf("min") + " on every axis");
    }
  }
  return box;
}

FluidBlock ParseFluidBlock(const json& j, const std::string& path) {
  ObjectReader r(j, path);
  FluidBlock b;
  b.center = r.Vector("center", -kMaxCoord, kMaxCoord, "m");
  b.size = r.Vector("size", 1e-6, kMaxCoord, "m", /*allow_scalar=*/true);
  if (const json* n = r.Get("particles_per_axis")) {
    const std::string p = r.PathOf("particles_per_axis");
    if (n->is_array()) {
      if (n->size() != 3) throw ConfigError(p, "expected 3 integers or one integer");
      Eigen::Vector3i counts;
      for (int a = 0; a < 3; ++a) {
        counts[a] = int(
            ObjectReader::CheckInteger((*n)[a], p + "[" + std::to_string(a) + "]", 1, kMaxPerAxis));
      }
      b.particles_per_axis = counts;
    } else {
      b.particles_per_axis =
          Eigen::Vector3i::Constant(int(ObjectReader::CheckInteger(*n, p, 1, kMaxPerAxis)));
    }
  }
  b.spacing = r.Number("spacing", 1e-5, kMaxCoord, "m");
  if (b.spacing && b.particles_per_axis) {
    throw ConfigError(r.PathOf("spacing"), "give either particles_per_axis or spacing, not both");
  }
  b.jitter = r.Number("jitter", 0, 100, "m");
  b.seed = static_cast<uint64_t>(r.Integer("seed", 0, int64_t{1} << 53).value_or(1));
  b.velocity = r.Vector("velocity", -kMaxSpeed, kMaxSpeed, "m/s").value_or(Vec3d::Zero());
  r.RejectUnknown();
  return b;
}

// The bound on motion times: the longest scene (end_time) runs 1e6 s.
constexpr double kMaxMotionTime = 1e6;  // s

// An obstacle's "motion": {"velocity": [vx, vy, vz], "start": t0, "end": t1} or
// {"path": [[t, dx, dy, dz], ...]}. `scene_keys` counts the keys of every obstacle so far.
ObstacleMotion ParseMotion(const json& j, const std::string& path, size_t& scene_keys) {
  ObjectReader r(j, path);
  ObstacleMotion motion;
  const json* keyframes = r.Get("path");
  const std::optional<Vec3d> velocity = r.Vector("velocity", -kMaxSpeed, kMaxSpeed, "m/s");
  const std::optional<double> start = r.Number("start", 0, kMaxMotionTime, "s");
  const std::optional<double> end = r.Number("end", 0, kMaxMotionTime, "s");
  r.RejectUnknown();
  if (keyframes != nullptr) {
    if (velocity || start || end) {
      throw ConfigError(r.PathOf(velocity ? "velocity"
                                 : start  ? "start"
                                          : "end"),
                        "give either path or velocity (with start and end), not both");
    }
    const std::string p = r.PathOf("path");
    if (!keyframes->is_array() || keyframes->empty() || keyframes->size() > kMaxMotionKeys) {
      throw ConfigError(
          p, "expected an array of 1 to " + std::to_string(kMaxMotionKeys) +
                 " keys [t, dx, dy, dz], got " +
                 (keyframes->is_array() ? "an array of " + std::to_string(keyframes->size())
                                        : TypeName(*keyframes)));
    }
    for (size_t i = 0; i < keyframes->size(); ++i) {
      const json& key = (*keyframes)[i];
      const std::string kp = p + "[" + std::to_string(i) + "]";
      if (!key.is_array() || key.size() != 4) {
        throw ConfigError(
            kp, "expected [t, dx, dy, dz] (s, m), got " +
                    (key.is_array() ? "an array of " + std::to_string(key.size()) : TypeName(key)));
      }
      ObstacleMotion::Key k;
      k.time = ObjectReader::CheckNumber(key[0], kp + "[0]", 0, kMaxMotionTime, "s");
      for (int a = 0; a < 3; ++a) {
        k.displacement[a] = ObjectReader::CheckNumber(
            key[size_t(a) + 1], kp + "[" + std::to_string(a + 1) + "]", -kMaxCoord, kMaxCoord, "m");
      }
      if (!motion.keys.empty() && !(k.time > motion.keys.back().time)) {
        throw ConfigError(kp + "[0]", "key times must strictly increase; " + Num(k.time) +
                                          " s follows " + Num(motion.keys.back().time) + " s");
      }
      motion.keys.push_back(k);
    }
  } else {
    if (!velocity) {
      throw ConfigError(r.PathOf("velocity"),
                        "is required (or give path: [[t, dx, dy, dz], ...] instead)");
    }
    const double t0 = start.value_or(0);
    const double t1 = end.value_or(kMaxMotionTime);
    if (!(t1 > t0)) {
      throw ConfigError(r.PathOf("end"),
                        "must exceed start (" + Num(t0) + " s); got " + Num(t1) + " s");
    }
    motion.keys = {{t0, Vec3d::Zero()}, {t1, *velocity * (t1 - t0)}};
  }
  scene_keys += motion.keys.size();
  if (scene_keys > kMaxSceneMotionKeys) {
    throw ConfigError(path, "the scene's obstacle motions have more than " +
                                std::to_string(kMaxSceneMotionKeys) + " keys in all");
  }
  return motion;
}

void ParseObstacle(const json& j, const std::string& path, Scene& scene, size_t& scene_keys) {
  ObjectReader r(j, path);
  const std::string type = r.String("type").value_or("");
  ObstacleMotion motion;
  if (type == "sphere" || type == "box") {
    if (const json* m = r.Get("motion")) motion = ParseMotion(*m, r.PathOf("motion"), scene_keys);
  }
  if (type == "sphere") {
    SphereObstacle s;
    s.center = r.Vector("center", -kMaxCoord, kMaxCoord, "m").value_or(Vec3d::Zero());
    s.radius = r.Number("radius", 1e-6, kMaxCoord, "m").value_or(s.radius);
    s.motion = std::move(motion);
    scene.spheres.push_back(std::move(s));
  } else if (type == "box") {
    const Vec3d center = r.Vector("center", -kMaxCoord, kMaxCoord, "m").value_or(Vec3d::Zero());
    const Vec3d size = r.Vector("size", 1e-6, kMaxCoord, "m", true).value_or(Vec3d::Ones());
    scene.boxes.push_back({Aabb{center - 0.5 * size, center + 0.5 * size}, std::move(motion)});
  } else {
    throw ConfigError(r.PathOf("type"), "expected \"sphere\" or \"box\", got " + Quoted(type));
  }
  r.RejectUnknown();
}

const std::map<std::string, ProbeKind>& ProbeKinds() {
  static const std::map<std::string, ProbeKind> kinds = {
      {"front", ProbeKind::kFront},
      {"height", ProbeKind::kHeight},
      {"pressure", ProbeKind::kPressure},
      {"wall_pressure", ProbeKind::kWallPressure},
      {"density", ProbeKind::kDensity},
      {"kinetic_energy", ProbeKind::kKineticEnergy},
      {"count_inside", ProbeKind::kCountInside},
      {"box_force", ProbeKind::kBoxForce},
  };
  return kinds;
}

// `box_of_obstacle`: for each entry of the scene's "obstacles", its index in Scene::boxes, or -1
// where it is a sphere.
ProbeSpec ParseProbe(const json& j, const std::string& path,
                     const std::vector<int>& box_of_obstacle) {
  ObjectReader r(j, path);
  const std::string type = r.String("type").value_or("");
  auto kind = ProbeKinds().find(type);
  if (kind == ProbeKinds().end()) {
    std::string names;
    for (const auto& [name, k] : ProbeKinds()) names += (names.empty() ? "" : ", ") + name;
    throw ConfigError(r.PathOf("type"), "unknown probe type " + Quoted(type) + "; known: " + names);
  }
  ProbeSpec p;
  p.kind = kind->second;
  p.name = r.String("name").value_or(type);
  CheckKeptText(p.name, r.PathOf("name"), kMaxSceneNameBytes, /*multiline=*/false);
  if (p.name.empty() || p.name.find_first_of(",\"") != std::string::npos) {
    throw ConfigError(r.PathOf("name"), "must be non-empty without commas or quotes");
  }
  switch (p.kind) {
    case ProbeKind::kFront: {
      const std::string axis = r.String("axis").value_or("x");
      if (axis != "x" && axis != "y" && axis != "z") {
        throw ConfigError(r.PathOf("axis"), "expected \"x\", \"y\" or \"z\", got " + Quoted(axis));
      }
      p.axis = axis[0] - 'x';
      break;
    }
    case ProbeKind::kHeight:
      p.point = r.Vector("point", -kMaxCoord, kMaxCoord, "m").value_or(Vec3d::Zero());
      p.radius = r.Number("radius", 0, kMaxCoord, "m").value_or(0);
      p.gap = r.Number("gap", 0, kMaxCoord, "m").value_or(0);
      break;
    case ProbeKind::kPressure:
      p.point = r.Vector("point", -kMaxCoord, kMaxCoord, "m").value_or(Vec3d::Zero());
      break;
    case ProbeKind::kWallPressure:
      if (r.Get("point") == nullptr) {
        throw ConfigError(r.PathOf("point"), "a wall_pressure probe needs its point on the face");
      }
      p.point = *r.Vector("point", -kMaxCoord, kMaxCoord, "m");
      // Any length: only its direction is used.
      p.normal = r.Vector("normal", -1e6, 1e6).value_or(Vec3d::Zero());
      break;
    case ProbeKind::kCountInside:
      if (const json* region = r.Get("region")) p.region = ParseBox(*region, r.PathOf("region"));
      break;
    case ProbeKind::kBoxForce: {
      if (box_of_obstacle.empty()) {
        throw ConfigError(r.PathOf("obstacle"),
                          "a box_force probe needs a box among the scene's obstacles; it has none");
      }
      const int64_t last = int64_t(box_of_obstacle.size()) - 1;
      if (r.Get("obstacle") == nullptr) {
        throw ConfigError(r.PathOf("obstacle"),
                          "a box_force probe needs the index of its box in \"obstacles\", an "
                          "integer in [0, " +
                              std::to_string(last) + "]");
      }
      const int64_t index = *r.Integer("obstacle", 0, last);
      p.box = box_of_obstacle[size_t(index)];
      if (p.box < 0) {
        throw ConfigError(r.PathOf("obstacle"), "obstacles[" + std::to_string(index) +
                                                    "] is a sphere; a box_force probe needs a box");
      }
      // Below a micrometre a face would hold more samples than BoxForceOn takes (it caps them).
      p.spacing = r.Number("spacing", 1e-6, kMaxCoord, "m").value_or(0);
      break;
    }
    case ProbeKind::kDensity:
    case ProbeKind::kKineticEnergy:
      break;
  }
  r.RejectUnknown();
  return p;
}

}  // namespace

namespace {

Scene ParseSceneDocument(const json& root) {
  ObjectReader r(root, "");
  Scene scene;
  scene.name = r.String("name").value_or("");
  CheckKeptText(scene.name, "name", kMaxSceneNameBytes, /*multiline=*/false);
  scene.description = r.String("description").value_or("");
  CheckKeptText(scene.description, "description", kMaxSceneDescriptionBytes, /*multiline=*/true);
  if (const json* domain = r.Get("domain")) {
    scene.domain = ParseBox(*domain, "domain", &scene);
  }
  ForEachElement(r, "fluid_blocks", [&](const json& j, const std::string& path) {
    scene.fluid_blocks.push_back(ParseFluidBlock(j, path));
  });
  if (const json* obstacles = r.Get("obstacles");
      obstacles && obstacles->is_array() && obstacles->size() > kMaxObstacles) {
    throw ConfigError("obstacles", "at most " + std::to_string(kMaxObstacles) + " obstacles; got " +
                                       std::to_string(obstacles->size()));
  }
  size_t motion_keys = 0;
  std::vector<int> box_of_obstacle;
  ForEachElement(r, "obstacles", [&](const json& j, const std::string& path) {
    const size_t boxes = scene.boxes.size();
    ParseObstacle(j, path, scene, motion_keys);
    box_of_obstacle.push_back(scene.boxes.size() > boxes ? int(boxes) : -1);
  });
  scene.solver = r.String("solver").value_or(scene.solver);
  // Throws ConfigError("solver", ...) quoting the name and listing the known solvers. It is
  // given the name as a message may quote it: that is the name itself for every registered
  // solver (short and printable), and never a registered name otherwise.
  FindSolver(SafeText(scene.solver));
  if (const json* params = r.Get("params")) {
    if (!params->is_object()) {
      throw ConfigError("params", "expected an object, got " + TypeName(*params));
    }
    for (const auto& [key, value] : params->items()) {
      const std::string path = "params." + SafeText(key);
      if (FindParam(key) == nullptr) {
        std::string known;
        for (const ParamDecl& d : ParamTable())
          known += (known.empty() ? "" : ", ") + std::string(d.name);
        throw ConfigError(path, "unknown parameter; known parameters: " + known);
      }
      if (!value.is_number()) {
        throw ConfigError(path, "expected a number in " + FindParam(key)->RangeText() + ", got " +
                                    TypeName(value));
      }
      try {
        SetParam(scene.params, key, value.get<double>());
      } catch (const ConfigError& e) {
        throw ConfigError(path, e.message());
      }
    }
  }
  scene.end_time = r.Number("end_time", 1e-6, 1e6, "s").value_or(scene.end_time);
  scene.probe_interval = r.Number("probe_interval", 1e-6, 1e6, "s");
  std::set<std::string> probe_names;
  ForEachElement(r, "probes", [&](const json& j, const std::string& path) {
    ProbeSpec p = ParseProbe(j, path, box_of_obstacle);
    if (!probe_names.insert(p.name).second) {
      throw ConfigError(path + ".name", "duplicate probe name " + Quoted(p.name));
    }
    scene.probes.push_back(std::move(p));
  });
  r.RejectUnknown();
  if (scene.fluid_blocks.empty()) scene.fluid_blocks.emplace_back();  // the thesis's spawn cube
  BlockParticleCounts(scene, scene.params);  // rejects counts that would exhaust memory
  CheckPeriodicDomain(scene, scene.params);
  return scene;
}

}  // namespace

Scene ParseScene(std::string_view json_text) {
  const json root = ParseSceneJson(json_text);
  try {
    Scene scene = ParseSceneDocument(root);
    scene.source_json = std::string(json_text);
    return scene;
  } catch (const json::exception& e) {
    // The reader checks every type before it reads a value, so this is a bug; still an error
    // that names the scene, not an exception a caller does not expect.
    throw ConfigError("", "invalid scene: " + SafeText(e.what(), 400));
  }
}

}  // namespace dysa
