// Writes the seed corpus of service_request_fuzzer: valid (and a few refused) requests of every
// type, alone and in sequences (layout in service_input.h). Usage: make_service_corpus DIR
#include <cstdio>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "dysa/v1/simulation.pb.h"
#include "service_input.h"

namespace {

using dysa::fuzz::AppendRequest;
using dysa::fuzz::RequestKind;
namespace v1 = dysa::v1;

std::string LoadName(const std::string& name, const std::string& solver = "") {
  v1::LoadSceneRequest r;
  r.set_name(name);
  if (!solver.empty()) r.set_solver(solver);
  return r.SerializeAsString();
}

std::string LoadJson(const std::string& json, const std::string& solver = "") {
  v1::LoadSceneRequest r;
  r.set_json_text(json);
  if (!solver.empty()) r.set_solver(solver);
  return r.SerializeAsString();
}

std::string Update(const std::vector<std::pair<std::string, double>>& values,
                   const std::vector<std::string>& mask = {}) {
  v1::UpdateParamsRequest r;
  for (const auto& [name, value] : values) (*r.mutable_params()->mutable_values())[name] = value;
  for (const std::string& path : mask) r.mutable_update_mask()->add_paths(path);
  return r.SerializeAsString();
}

std::string Step(uint32_t count) {
  v1::StepRequest r;
  r.set_count(count);
  return r.SerializeAsString();
}

std::string StepBack(uint32_t count) {
  v1::StepBackRequest r;
  r.set_count(count);
  return r.SerializeAsString();
}

std::string Stream(std::vector<v1::Field> fields, uint32_t position_bits, uint32_t stride,
                   uint32_t keyframe_interval, v1::VelocityEncoding encoding, double max_fps) {
  v1::StreamFramesRequest r;
  for (v1::Field f : fields) r.add_fields(f);
  r.set_position_bits(position_bits);
  r.set_velocity_bits(position_bits > 12 ? 12 : position_bits);
  r.set_stride(stride);
  r.set_keyframe_interval(keyframe_interval);
  r.set_velocity_encoding(encoding);
  r.set_max_fps(max_fps);
  return r.SerializeAsString();
}

// A scene of 27 particles, small enough for the fuzzer's host (512 at most).
const char* kTinyWcsph = R"({"name": "tiny", "description": "27 particles\nfor the fuzzer",
  "domain": {"min": [-0.5, -0.5, -0.5], "max": [0.5, 0.5, 0.5], "periodic": ["x"]},
  "fluid_blocks": [{"center": [0, -0.3, 0], "size": [0.12, 0.12, 0.12]}],
  "solver": "wcsph", "params": {"particle_spacing": 0.04}})";
const char* kTinySeed = R"({"name": "tiny_seed",
  "domain": {"min": [-1, -1, -1], "max": [1, 1, 1]},
  "fluid_blocks": [{"particles_per_axis": [3, 3, 3], "size": [0.5, 0.5, 0.5],
                    "velocity": [1, 0, 0]}],
  "spheres": [{"center": [0, -0.7, 0], "radius": 0.2}],
  "solver": "seed", "params": {"particle_quantity": 3, "smoothing_radius": 0.3}})";

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_service_corpus DIR\n");
    return 2;
  }
  const std::string dir = argv[1];
  std::vector<std::pair<std::string, std::string>> seeds;
  auto one = [&](const char* name, RequestKind kind, const std::string& bytes) {
    std::string input;
    AppendRequest(input, kind, bytes);
    seeds.emplace_back(name, input);
  };
  one("load_builtin", RequestKind::kLoadScene, LoadName("seed_basic"));
  one("load_builtin_dfsph", RequestKind::kLoadScene, LoadName("hydrostatic_tank", "dfsph"));
  one("load_json_wcsph", RequestKind::kLoadScene, LoadJson(kTinyWcsph));
  one("load_json_seed", RequestKind::kLoadScene, LoadJson(kTinySeed));
  one("load_json_other_solver", RequestKind::kLoadScene, LoadJson(kTinyWcsph, "dfsph"));
  one("update", RequestKind::kUpdateParams, Update({{"gravity", -5}, {"viscosity", 0.01}}));
  one("update_masked", RequestKind::kUpdateParams,
      Update({{"gravity", -5}, {"particle_quantity", 3}}, {"values.particle_quantity"}));
  one("update_out_of_range", RequestKind::kUpdateParams, Update({{"smoothing_radius", -1}}));
  one("step", RequestKind::kStep, Step(1));
  one("step_many", RequestKind::kStep, Step(20000));
  one("step_back", RequestKind::kStepBack, StepBack(1));
  one("stream", RequestKind::kStreamFrames,
      Stream({v1::FIELD_VELOCITY, v1::FIELD_DENSITY}, 10, 2, 3, v1::VELOCITY_ENCODING_OCTAHEDRAL,
             30));
  one("stream_default", RequestKind::kStreamFrames, "");
  one("pause", RequestKind::kPause, "");
  one("resume", RequestKind::kResume, "");
  one("reset", RequestKind::kReset, "");
  one("read", RequestKind::kRead, "");

  std::string sequence;
  AppendRequest(sequence, RequestKind::kStep, Step(3));
  AppendRequest(sequence, RequestKind::kStepBack, StepBack(2));
  AppendRequest(sequence, RequestKind::kUpdateParams, Update({{"particle_quantity", 3}}));
  AppendRequest(sequence, RequestKind::kStep, Step(1));
  AppendRequest(sequence, RequestKind::kStepBack, StepBack(5));
  AppendRequest(sequence, RequestKind::kRead, "");
  seeds.emplace_back("sequence_step_back_update", sequence);
  sequence.clear();
  AppendRequest(sequence, RequestKind::kLoadScene, LoadJson(kTinyWcsph));
  AppendRequest(sequence, RequestKind::kStreamFrames,
                Stream({v1::FIELD_SPEED}, 24, 1, 1, v1::VELOCITY_ENCODING_COMPONENTS, 0));
  AppendRequest(sequence, RequestKind::kUpdateParams, Update({{"particle_spacing", 0.05}}));
  AppendRequest(sequence, RequestKind::kReset, "");
  AppendRequest(sequence, RequestKind::kStep, Step(2));
  AppendRequest(sequence, RequestKind::kRead, "");
  seeds.emplace_back("sequence_load_stream_update", sequence);
  sequence.clear();
  AppendRequest(sequence, RequestKind::kResume, "");
  AppendRequest(sequence, RequestKind::kUpdateParams, Update({{"time_scale", 2}}));
  AppendRequest(sequence, RequestKind::kPause, "");
  AppendRequest(sequence, RequestKind::kStepBack, StepBack(1));
  seeds.emplace_back("sequence_resume_update_pause", sequence);

  for (const auto& [name, bytes] : seeds) {
    std::ofstream out(dir + "/" + name, std::ios::binary);
    out << bytes;
    if (!out) {
      std::fprintf(stderr, "make_service_corpus: cannot write %s/%s\n", dir.c_str(), name.c_str());
      return 1;
    }
  }
  std::printf("make_service_corpus: %zu seeds in %s\n", seeds.size(), dir.c_str());
  return 0;
}
