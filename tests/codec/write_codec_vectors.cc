// Writes cross-language test vectors of the frame codec: encoded chunks and what the C++ decoder
// makes of them, for tests/python/test_codec.py to check the Python decoder against, bit for bit.
//
// Usage: write_codec_vectors DIR
//
// DIR/manifest.json lists the scenarios, each with its frames in stream order. Per frame: its
// chunk files (raw bytes, in encoding order), the decoded arrays (raw little-endian float32, null
// for an absent field), the metadata and the error bounds. Doubles are hex floats ("%a"), exact.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "codec/frame_codec_test_util.h"
#include "dysa/codec/detail_subset.h"
#include "dysa/codec/frame_codec.h"

namespace {

namespace fs = std::filesystem;
using dysa::codec::Chunk;
using dysa::codec::Frame;
using dysa::codec::FrameDecoder;
using dysa::codec::FrameEncoder;
using dysa::codec::StreamConfig;
using dysa::codec::testing::Input;
using dysa::codec::testing::SyntheticFrames;
using nlohmann::json;

constexpr uint32_t kAllFields =
    dysa::codec::kPositions | dysa::codec::kSpeed | dysa::codec::kVelocity | dysa::codec::kDensity;

struct Scenario {
  std::string name;
  StreamConfig config;
  uint32_t particles = 0;
  int frames = 0;
  std::vector<bool> keyframes;  // the keyframe flag each frame must get (the vectors' coverage)
  // With config.explicit_ids: the ids of frame f are those with (id * 7 + subset[f]) % 10 < 4.
  std::vector<uint32_t> subset;
};

std::vector<uint32_t> SubsetIds(uint32_t particles, uint32_t shift) {
  std::vector<uint32_t> ids;
  for (uint32_t i = 0; i < particles; ++i) {
    if ((i * 7 + shift) % 10 < 4) ids.push_back(i);
  }
  return ids;
}

std::string Hex(double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%a", v);
  return buffer;
}

void WriteFile(const fs::path& path, const void* data, size_t size) {
  std::ofstream out(path, std::ios::binary);
  out.write(static_cast<const char*>(data), std::streamsize(size));
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

// Writes one decoded array; returns its file name relative to the manifest, or null if absent.
json WriteArray(const fs::path& dir, const std::string& scenario, const std::string& name,
                bool present, const std::vector<float>& values) {
  if (!present) return nullptr;
  const std::string file = scenario + "/" + name + ".f32";
  WriteFile(dir / file, values.data(), values.size() * sizeof(float));
  return file;
}

json WriteScenario(const fs::path& dir, const Scenario& s) {
  fs::create_directories(dir / s.name);
  SyntheticFrames source(s.particles);
  FrameEncoder encoder(s.config);
  FrameDecoder decoder;
  std::vector<float> x, v, rho;
  json frames = json::array();
  for (int f = 0; f < s.frames; ++f) {
    source.Make(f, x, v, rho);
    dysa::codec::FrameInput input = Input(x, v, rho, 1000 + 10 * f, f / 60.0);
    const std::vector<uint32_t> ids = s.config.explicit_ids
                                          ? SubsetIds(s.particles, s.subset[size_t(f)])
                                          : std::vector<uint32_t>();
    input.ids = ids;
    const std::vector<Chunk> chunks = encoder.Encode(input);
    const std::string prefix = "frame" + std::to_string(f);
    json chunk_files = json::array();
    std::optional<Frame> frame;
    for (size_t c = 0; c < chunks.size(); ++c) {
      const std::string file = s.name + "/" + prefix + "_chunk" + std::to_string(c) + ".bin";
      WriteFile(dir / file, chunks[c].data(), chunks[c].size());
      chunk_files.push_back(file);
      std::optional<Frame> got = decoder.AddChunk(chunks[c]);
      if (got.has_value() != (c + 1 == chunks.size())) {
        throw std::runtime_error(s.name + " " + prefix + ": frame not complete at its last chunk");
      }
      if (got) frame = std::move(got);
    }
    if (frame->keyframe != s.keyframes[size_t(f)]) {
      throw std::runtime_error(s.name + " " + prefix + ": unexpected keyframe flag");
    }
    json entry;
    entry["frame_seq"] = frame->frame_seq;
    entry["step"] = frame->step;
    entry["time"] = Hex(frame->time);
    entry["keyframe"] = frame->keyframe;
    entry["count"] = frame->count;
    entry["stride"] = frame->stride;
    entry["detail_threshold"] = frame->detail_threshold;
    entry["ids"] = dysa::codec::ParticleIds(*frame);
    entry["fields"] = frame->fields;
    entry["chunks"] = chunk_files;
    const uint32_t fields = frame->fields;
    entry["positions"] = WriteArray(dir, s.name, prefix + "_positions", true, frame->positions);
    entry["speed"] =
        WriteArray(dir, s.name, prefix + "_speed", fields & dysa::codec::kSpeed, frame->speed);
    entry["velocities"] = WriteArray(dir, s.name, prefix + "_velocities",
                                     fields & dysa::codec::kVelocity, frame->velocities);
    entry["densities"] = WriteArray(dir, s.name, prefix + "_densities",
                                    fields & dysa::codec::kDensity, frame->densities);
    entry["position_error"] = {Hex(frame->position_error[0]), Hex(frame->position_error[1]),
                               Hex(frame->position_error[2])};
    entry["speed_error"] = Hex(frame->speed_error);
    entry["velocity_error"] = Hex(frame->velocity_error);
    entry["density_error"] = Hex(frame->density_error);
    frames.push_back(entry);
  }
  json scenario;
  scenario["name"] = s.name;
  scenario["particles"] = s.particles;
  scenario["frames"] = frames;
  return scenario;
}

std::vector<Scenario> Scenarios() {
  std::vector<Scenario> out;
  {
    // Every field at the default bits, three chunks; keyframes at 0 and 4. The delta frames are
    // predicted from one frame (1, 5), two (2) and three (3).
    Scenario s;
    s.name = "a_all_fields";
    s.particles = 3000;
    s.frames = 6;
    s.config.fields = kAllFields;
    s.config.chunk_particles = 1000;
    s.config.keyframe_interval = 4;
    s.keyframes = {true, false, false, false, true, false};
    out.push_back(s);
  }
  {
    // Positions and speed at low bits, every third particle, chunks of unequal size.
    Scenario s;
    s.name = "b_stride_low_bits";
    s.particles = 2500;
    s.frames = 4;
    s.config.fields = dysa::codec::kPositions | dysa::codec::kSpeed;
    s.config.position_bits = 11;
    s.config.speed_bits = 5;
    s.config.stride = 3;
    s.config.chunk_particles = 300;
    s.keyframes = {true, false, false, false};
    out.push_back(s);
  }
  {
    // No particles: a keyframe and a delta frame of one empty chunk each. Without velocity: the
    // encoder gives an empty keyframe with velocity an infinite velocity range, which decoders
    // refuse (FrameEncoder::Encode sets the range of velocity x from y and z before their empty
    // ranges are replaced).
    Scenario s;
    s.name = "c_empty";
    s.particles = 0;
    s.frames = 2;
    s.config.fields = dysa::codec::kPositions | dysa::codec::kSpeed | dysa::codec::kDensity;
    s.keyframes = {true, false};
    out.push_back(s);
  }
  {
    // The extremes of the bit widths (24-bit positions need all 4 byte planes in a keyframe,
    // 1-bit velocity and density); a keyframe every 5 frames, so the history of 3 frames that
    // delta frames are predicted from fills and then slides (frame 4).
    Scenario s;
    s.name = "d_extreme_bits";
    s.particles = 700;
    s.frames = 7;
    s.config.fields = kAllFields;
    s.config.position_bits = 24;
    s.config.speed_bits = 16;
    s.config.velocity_bits = 1;
    s.config.density_bits = 1;
    s.config.chunk_particles = 256;
    s.config.keyframe_interval = 5;
    s.keyframes = {true, false, false, false, false, true, false};
    out.push_back(s);
  }
  {
    // Velocity as |v| and octahedral direction (format version 2), with speed, keyframes and
    // delta frames of every prediction order.
    Scenario s;
    s.name = "e_octahedral_velocity";
    s.particles = 1500;
    s.frames = 6;
    s.config.fields = dysa::codec::kPositions | dysa::codec::kSpeed | dysa::codec::kVelocity;
    s.config.velocity_encoding = dysa::codec::VelocityEncoding::kOctahedral;
    s.config.velocity_bits = 10;
    s.config.chunk_particles = 400;
    s.config.keyframe_interval = 5;
    s.keyframes = {true, false, false, false, false, true};
    out.push_back(s);
  }
  {
    // A subset by rank (format version 3): the ids follow from the header's threshold.
    Scenario s;
    s.name = "f_detail_subset";
    s.particles = 3000;
    s.frames = 4;
    s.config.fields = dysa::codec::kPositions | dysa::codec::kSpeed;
    s.config.detail_threshold = dysa::codec::DetailThreshold(0.3);
    s.config.chunk_particles = 300;
    s.keyframes = {true, false, false, false};
    out.push_back(s);
  }
  {
    // Explicit ids (format version 4): in keyframes only; the subset changes at frame 2, which
    // makes it a keyframe.
    Scenario s;
    s.name = "g_explicit_ids";
    s.particles = 3000;
    s.frames = 4;
    s.config.fields = kAllFields;
    s.config.explicit_ids = true;
    s.config.chunk_particles = 350;
    s.subset = {0, 0, 3, 3};
    s.keyframes = {true, false, true, false};
    out.push_back(s);
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: " << argv[0] << " DIR\n";
    return 2;
  }
  try {
    const fs::path dir = argv[1];
    fs::create_directories(dir);
    json manifest;
    manifest["format_version"] = dysa::codec::kVersion;
    manifest["scenarios"] = json::array();
    for (const Scenario& s : Scenarios()) manifest["scenarios"].push_back(WriteScenario(dir, s));
    std::ofstream out(dir / "manifest.json");
    out << manifest.dump(1) << "\n";
    if (!out) throw std::runtime_error("cannot write manifest.json");
  } catch (const std::exception& e) {
    std::cerr << "write_codec_vectors: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
