// dysa record: frames to a ParaView series (vtk) or a NumPy .npz file.
#include <atomic>
#include <chrono>
#include <cstring>
#include <exception>
#include <filesystem>
#include <functional>
#include <memory>
#include <ostream>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "dysa/client/frame_assembler.h"
#include "npz_writer.h"
#include "remote_commands.h"
#include "remote_format.h"
#include "stream_watchdog.h"
#include "vtk_writer.h"

namespace dysa::remote {
namespace {

namespace fs = std::filesystem;

std::vector<char> FloatBytes(const std::vector<float>& values) {
  std::vector<char> bytes(values.size() * sizeof(float));
  if (!bytes.empty()) std::memcpy(bytes.data(), values.data(), bytes.size());
  return bytes;
}

VtpPoints ToVtp(const codec::Frame& frame) {
  VtpPoints points;
  points.positions = frame.positions;
  const std::vector<uint32_t> ids = codec::ParticleIds(frame);
  VtpArray id{"id", "UInt32", 1, std::vector<char>(ids.size() * sizeof(uint32_t))};
  if (!ids.empty()) std::memcpy(id.bytes.data(), ids.data(), id.bytes.size());
  points.arrays.push_back(std::move(id));
  if (frame.fields & codec::kSpeed) {
    points.arrays.push_back({"speed", "Float32", 1, FloatBytes(frame.speed)});
    points.scalars = "speed";
  }
  if (frame.fields & codec::kVelocity) {
    points.arrays.push_back({"velocity", "Float32", 3, FloatBytes(frame.velocities)});
    points.vectors = "velocity";
  }
  if (frame.fields & codec::kDensity) {
    points.arrays.push_back({"density", "Float32", 1, FloatBytes(frame.densities)});
    if (points.scalars.empty()) points.scalars = "density";
  }
  return points;
}

// The frames of an npz recording, appended frame by frame: (F, N, ...) arrays in C order.
struct NpzFrames {
  uint32_t count = 0;         // N
  std::vector<uint32_t> ids;  // N, the same in every frame
  uint32_t threshold = 0;     // the frames' detail threshold (0: every stride-th particle)
  uint32_t fields = 0;
  std::vector<float> positions, speed, velocity, density;
  std::vector<double> time;
  std::vector<uint64_t> step, frame;

  // Returns why the frame cannot join the others, or "".
  std::string Append(const codec::Frame& f, uint64_t frame_number) {
    if (time.empty()) {
      count = f.count, fields = f.fields, threshold = f.detail_threshold;
      ids = codec::ParticleIds(f);
    } else if (f.detail_threshold != threshold) {
      return "the frame's particles changed at frame " + std::to_string(frame_number) +
             " (the server changed the detail to fit --fps-target or --byte-budget; record a "
             "fixed subset with --particle-budget alone, or to vtk)";
    } else if (f.count != count || f.fields != fields) {
      return "the frame changed from " + std::to_string(count) + " particles (" +
             FieldNames(fields) + ") to " + std::to_string(f.count) + " (" + FieldNames(f.fields) +
             ") at frame " + std::to_string(frame_number) + " (a reset or a new scene?)";
    } else if (f.explicit_ids && f.ids != ids) {
      return "the frame's particles changed at frame " + std::to_string(frame_number) +
             " (a stream with --view selects its particles again as the fluid and the view "
             "move; record it to vtk)";
    }
    positions.insert(positions.end(), f.positions.begin(), f.positions.end());
    if (fields & codec::kSpeed) speed.insert(speed.end(), f.speed.begin(), f.speed.end());
    if (fields & codec::kVelocity) {
      velocity.insert(velocity.end(), f.velocities.begin(), f.velocities.end());
    }
    if (fields & codec::kDensity) {
      density.insert(density.end(), f.densities.begin(), f.densities.end());
    }
    time.push_back(f.time);
    step.push_back(f.step);
    frame.push_back(frame_number);
    return "";
  }

  void Write(const fs::path& path) const {
    const size_t frames = time.size(), n = count;
    NpzWriter npz(path);
    npz.Add("positions", std::span<const float>(positions), {frames, n, 3});
    if (fields & codec::kSpeed) npz.Add("speed", std::span<const float>(speed), {frames, n});
    if (fields & codec::kVelocity) {
      npz.Add("velocity", std::span<const float>(velocity), {frames, n, 3});
    }
    if (fields & codec::kDensity) {
      npz.Add("density", std::span<const float>(density), {frames, n});
    }
    npz.Add("time", std::span<const double>(time), {frames});
    npz.Add("step", std::span<const uint64_t>(step), {frames});
    npz.Add("frame", std::span<const uint64_t>(frame), {frames});
    npz.Add("ids", std::span<const uint32_t>(ids), {n});
    npz.Close();
  }
};

}  // namespace

void Record(Client& client, const RecordOptions& options, std::ostream& out, std::ostream& err) {
  const fs::path path(options.out);
  std::string format = options.format;
  if (format.empty()) format = path.extension() == ".npz" ? "npz" : "vtk";
  if (format != "npz" && format != "vtk") {
    throw UsageError("--format: '" + format + "' is not vtk or npz");
  }
  if (options.frames == 0) throw UsageError("--frames: must be at least 1");
  if (path.filename().empty()) throw UsageError("--out: '" + options.out + "' names no file");
  // Missing directories are made, as `dysa run --out` makes its own, before any frame arrives.
  const fs::path parent = path.parent_path();
  std::error_code error;
  if (!parent.empty() && !fs::create_directories(parent, error) && !fs::is_directory(parent)) {
    throw std::runtime_error("cannot write " + options.out + ": cannot make the directory " +
                             parent.string() + (error ? ": " + error.message() : ""));
  }

  // vtk: OUT.pvd and OUT/frame_NNNNNN.vtp, written as frames arrive.
  std::unique_ptr<VtkSeriesWriter> vtk;
  fs::path written = path;
  if (format == "vtk") {
    const std::string name =
        path.extension() == ".pvd" ? path.stem().string() : path.filename().string();
    vtk = std::make_unique<VtkSeriesWriter>(parent, name);
    written = parent / (name + ".pvd");
  }
  NpzFrames npz;

  if (client.GetStatus().state == "paused") {
    err << "dysa record: note: the simulation is paused; frames arrive as it steps "
           "(dysa resume, dysa step N)\n";
  }
  std::unique_ptr<FrameStream> stream = client.StreamFrames(options.stream);
  std::atomic<uint64_t> got{0};
  std::function<void()> tick;
  if (options.progress) {
    tick = [&] {
      err << "\rrecording: " << got << "/" << options.frames << " frames" << std::flush;
    };
  }
  StreamWatchdog watchdog(*stream, options.interrupted, 0, std::chrono::milliseconds(250), tick);

  FrameAssembler assembler;
  codec::Frame frame;
  FrameMessage message;
  uint64_t decode_errors = 0;
  std::string stop_reason;
  uint32_t first_count = 0, fields = 0;
  bool camera_sent = false;
  while (got < options.frames && stream->Next(message)) {
    const FrameProgress progress = assembler.Add(message, frame);
    if (options.camera && !camera_sent && progress.stream_id != 0) {
      client.SetStreamView(progress.stream_id, *options.camera);  // RpcError: a bad camera
      camera_sent = true;
    }
    if (progress.decode_error) ++decode_errors;  // the decoder waits for the next keyframe
    if (!progress.complete) continue;
    if (got == 0) first_count = frame.count, fields = frame.fields;
    if (vtk) {
      vtk->WriteFrame(ToVtp(frame), frame.time);
    } else {
      stop_reason = npz.Append(frame, message.frame);
      if (!stop_reason.empty()) break;
    }
    ++got;
  }
  watchdog.Stop();
  if (options.progress) err << "\n";

  // The frames received are written whatever ended the stream; errors come after.
  std::exception_ptr stream_error;
  if (got < options.frames && stop_reason.empty() && !watchdog.ended()) {
    try {
      stream->Finish();
      stop_reason = "the server ended the stream";
    } catch (const std::exception&) {
      stream_error = std::current_exception();
    }
  } else {
    stream->Cancel();
    try {
      stream->Finish();
    } catch (const RpcError&) {
      // What we asked for has arrived; how the stream ended after that does not matter.
    }
  }
  if (watchdog.ended() && got < options.frames) stop_reason = "interrupted";
  if (!vtk && got > 0) npz.Write(path);

  if (options.json) {
    PrintJson({{"frames", got.load()},
               {"requested", options.frames},
               {"format", format},
               {"out", written.string()},
               {"particles", first_count},
               {"fields", FieldNames(fields)},
               {"decode_errors", decode_errors}},
              out);
  } else if (got > 0) {
    out << "recorded " << got << " frame" << (got == 1 ? "" : "s") << " of " << first_count
        << " particles (" << FieldNames(fields) << ") to " << written.string() << "\n";
  }
  if (stream_error) std::rethrow_exception(stream_error);
  if (!stop_reason.empty()) {
    throw std::runtime_error(stop_reason + " after " + std::to_string(got) + " of " +
                             std::to_string(options.frames) + " frames" +
                             (got > 0 ? "; they are in " + written.string() : ""));
  }
}
}  // namespace dysa::remote
