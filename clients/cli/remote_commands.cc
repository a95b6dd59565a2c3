#include "remote_commands.h"

#include <array>
#include <charconv>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <deque>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <mutex>
#include <nlohmann/json.hpp>
#include <ostream>
#include <set>
#include <sstream>
#include <thread>

#include "dysa/client/frame_assembler.h"
#include "npz_writer.h"
#include "vtk_writer.h"

namespace dysa::remote {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;  // keys in the order written, as in the proto
using Clock = std::chrono::steady_clock;

// ---------------------------------------------------------------------------------------------
// Formatting.

std::string Fixed(double value, int decimals) {
  std::ostringstream text;
  text << std::fixed << std::setprecision(decimals) << value;
  return text.str();
}

// Six significant digits, as a parameter is usually written ("0.001", "28.8", "1e+06").
std::string Short(double value) {
  std::ostringstream text;
  text << value;
  return text.str();
}

std::string HumanBytes(double bytes) {
  static constexpr const char* kUnits[] = {"B", "kB", "MB", "GB", "TB"};
  int unit = 0;
  while (std::abs(bytes) >= 1000 && unit < 4) bytes /= 1000, ++unit;
  return Fixed(bytes, unit == 0 ? 0 : 1) + " " + kUnits[unit];
}

// Where the server's simulation steps: "cpu", or the GPU and the memory the simulation holds on
// it ("cuda:0 NVIDIA H200, 139.8 GiB, sm_90; 52.4 MB held").
std::string DeviceText(const ServerStatus& s) {
  if (s.device.empty()) return "not reported (an older server)";
  if (s.device_memory_bytes == 0) return s.device;
  return s.device + "; " + HumanBytes(double(s.device_memory_bytes)) + " held";
}

// Rows of cells printed as columns, each as wide as its widest cell; `right` columns are
// right-aligned (numbers).
void PrintTable(const std::vector<std::vector<std::string>>& rows, const std::set<size_t>& right,
                std::ostream& out) {
  std::vector<size_t> width;
  for (const auto& row : rows) {
    width.resize(std::max(width.size(), row.size()));
    for (size_t c = 0; c < row.size(); ++c) width[c] = std::max(width[c], row[c].size());
  }
  for (const auto& row : rows) {
    std::string line;
    for (size_t c = 0; c < row.size(); ++c) {
      const std::string pad(width[c] - row[c].size(), ' ');
      line += right.count(c) ? pad + row[c] : row[c] + (c + 1 < row.size() ? pad : "");
      if (c + 1 < row.size()) line += "  ";
    }
    while (!line.empty() && line.back() == ' ') line.pop_back();
    out << line << "\n";
  }
}

std::string FieldNames(uint32_t fields) {
  std::string names;
  const std::pair<uint32_t, const char*> all[] = {{codec::kPositions, "positions"},
                                                  {codec::kSpeed, "speed"},
                                                  {codec::kVelocity, "velocity"},
                                                  {codec::kDensity, "density"}};
  for (const auto& [bit, name] : all) {
    if (fields & bit) names += (names.empty() ? "" : ", ") + std::string(name);
  }
  return names;
}

// ---------------------------------------------------------------------------------------------
// JSON, with the proto's field names.

Json ToJson(const ServerStatus& s) {
  Json passes = Json::array();
  for (const PassTiming& p : s.passes) {
    passes.push_back(
        {{"name", p.name}, {"last_ms", p.last_ms}, {"mean_ms", p.mean_ms}, {"calls", p.calls}});
  }
  return {{"state", s.state},
          {"step", s.step},
          {"frame", s.frame},
          {"time", s.time},
          {"particles", s.particles},
          {"solver", s.solver},
          {"scene", s.scene},
          {"frames_per_second", s.frames_per_second},
          {"target_frame_rate", s.target_frame_rate},
          {"passes", passes},
          {"subscribers", s.subscribers},
          {"alarm", s.alarm},
          {"warning", s.warning},
          {"history_frames", s.history_frames},
          {"history_bytes", s.history_bytes},
          {"frames_encoded", s.frames_encoded},
          {"state_hash", s.state_hash},
          {"scene_version", s.scene_version},
          {"solver_threads", s.solver_threads},
          {"device", s.device},
          {"device_memory_bytes", s.device_memory_bytes}};
}

Json ToJson(const ControlResult& r) {
  return {{"status", ToJson(r.status)}, {"reset", r.reset}, {"frames_moved", r.frames_moved}};
}

Json ToJson(const std::vector<ParamInfo>& params) {
  Json out = Json::array();
  for (const ParamInfo& p : params) {
    out.push_back({{"name", p.name},
                   {"value", p.value},
                   {"unit", p.unit},
                   {"min", p.min},
                   {"max", p.max},
                   {"default_value", p.default_value},
                   {"integer", p.integer},
                   {"needs_reset", p.needs_reset},
                   {"description", p.description}});
  }
  return out;
}

// A vector as [x, y, z].
Json ToJson(const std::array<double, 3>& v) { return Json::array({v[0], v[1], v[2]}); }

Json ToJson(const SceneDescription& s) {
  Json spheres = Json::array();
  for (const SphereObstacle& o : s.spheres) {
    spheres.push_back({{"center", ToJson(o.center)}, {"radius", o.radius}});
  }
  Json boxes = Json::array();
  for (const BoxObstacle& o : s.boxes) {
    boxes.push_back({{"min", ToJson(o.min)}, {"max", ToJson(o.max)}});
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
  return "[" + Short(v[0]) + ", " + Short(v[1]) + ", " + Short(v[2]) + "]";
}

void PrintJson(const Json& json, std::ostream& out) { out << json.dump(2) << "\n"; }

// "frame 12 (t = 0.2000 s, step 36)"
std::string Where(const ServerStatus& s) {
  return "frame " + std::to_string(s.frame) + " (t = " + Fixed(s.time, 4) + " s, step " +
         std::to_string(s.step) + ")";
}

// ---------------------------------------------------------------------------------------------
// Streams.

// Runs beside the blocking reads of a stream: cancels it on an interruption (Ctrl-C) or once
// `seconds` have passed, and calls `tick` every `period` (to print progress). A thread of its
// own because a blocked Read() cannot look at the clock or a flag.
class StreamWatchdog {
 public:
  StreamWatchdog(FrameStream& stream, const std::atomic<bool>* interrupted, double seconds,
                 Clock::duration period, std::function<void()> tick)
      : stream_(stream),
        interrupted_(interrupted),
        seconds_(seconds),
        period_(period),
        tick_(std::move(tick)),
        thread_([this] { Run(); }) {}
  ~StreamWatchdog() { Stop(); }
  StreamWatchdog(const StreamWatchdog&) = delete;
  StreamWatchdog& operator=(const StreamWatchdog&) = delete;

  void Stop() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
  }
  // The stream was cancelled by an interruption or the end of `seconds`.
  bool ended() const { return ended_; }
  bool interrupted() const { return interrupted_ != nullptr && interrupted_->load(); }

 private:
  void Run() {
    const Clock::time_point start = Clock::now();
    const Clock::time_point end =
        start + std::chrono::duration_cast<Clock::duration>(
                    std::chrono::duration<double>(seconds_ > 0 ? seconds_ : 0));
    Clock::time_point next_tick = start + period_;
    std::unique_lock lock(mutex_);
    while (!stop_) {
      wake_.wait_for(lock, std::chrono::milliseconds(50));
      if (stop_) break;
      const Clock::time_point now = Clock::now();
      if (interrupted() || (seconds_ > 0 && now >= end)) {
        ended_ = true;
        stream_.Cancel();
        break;
      }
      if (tick_ && now >= next_tick) {
        lock.unlock();
        tick_();
        lock.lock();
        next_tick = std::max(next_tick + period_, now);
      }
    }
  }

  FrameStream& stream_;
  const std::atomic<bool>* interrupted_;
  double seconds_;
  Clock::duration period_;
  std::function<void()> tick_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
  std::atomic<bool> ended_{false};
  std::thread thread_;  // last: starts once the members above exist
};

// What `watch` shows, updated by the reading thread and printed by the watchdog's.
struct WatchStats {
  std::mutex mutex;
  Clock::time_point start = Clock::now();
  uint64_t frames = 0;  // complete, decoded
  uint64_t bytes = 0;   // of those frames
  uint64_t frames_skipped = 0;
  uint64_t decode_errors = 0;
  std::deque<Clock::time_point> recent;  // when the frames of the last second completed
  // The latest frame.
  bool have_frame = false;
  uint64_t frame = 0;
  double time = 0;
  uint32_t particles = 0;
  uint64_t frame_bytes = 0;
  double latency_ms = 0;

  void Trim(Clock::time_point now) {
    while (!recent.empty() && now - recent.front() > std::chrono::seconds(1)) recent.pop_front();
  }

  double RecentRate(Clock::time_point now) {
    Trim(now);
    const double window = std::min(std::chrono::duration<double>(now - start).count(), 1.0);
    return window > 0 ? double(recent.size()) / window : 0;
  }

  std::string Line(const std::string& address) {
    std::lock_guard lock(mutex);
    const Clock::time_point now = Clock::now();
    const double rate = RecentRate(now);
    if (!have_frame) {
      const double waited = std::chrono::duration<double>(now - start).count();
      return "waiting for frames from " + address +
             (waited >= 2 ? " (" + Fixed(waited, 0) + " s; is the simulation paused?)" : "");
    }
    std::string line = "frame " + std::to_string(frame) + "  t " + Fixed(time, 3) + " s  " +
                       std::to_string(particles) + " particles  " + Fixed(rate, 1) + " frames/s  " +
                       HumanBytes(double(frame_bytes)) + "/frame  " +
                       Fixed(particles ? double(frame_bytes) / particles : 0, 2) +
                       " B/particle  latency " + Fixed(latency_ms, 1) + " ms";
    if (frames_skipped) line += "  skipped " + std::to_string(frames_skipped);
    if (decode_errors) line += "  decode errors " + std::to_string(decode_errors);
    return line;
  }
};

}  // namespace

// ---------------------------------------------------------------------------------------------
// Queries and controls.

void PrintStatus(Client& client, bool json, std::ostream& out) {
  const ServerStatus s = client.GetStatus();
  if (json) return PrintJson(ToJson(s), out);
  std::vector<std::vector<std::string>> rows = {
      {"scene", s.scene + " (solver " + s.solver + ", " + std::to_string(s.solver_threads) +
                    (s.solver_threads == 1 ? " thread)" : " threads)")},
      {"device", DeviceText(s)},
      {"state", s.state},
      {"frame", std::to_string(s.frame)},
      {"step", std::to_string(s.step)},
      {"time", Fixed(s.time, 4) + " s"},
      {"particles", std::to_string(s.particles)},
      {"rate", Fixed(s.frames_per_second, 1) + " frames/s (target " +
                   (s.target_frame_rate > 0 ? Short(s.target_frame_rate) : "unlimited") + ")"},
      {"subscribers", std::to_string(s.subscribers)},
      {"history",
       std::to_string(s.history_frames) + " frames, " + HumanBytes(double(s.history_bytes))},
      {"encoded", std::to_string(s.frames_encoded) + " frames"},
  };
  if (s.state_hash != 0) {
    char hash[20];
    std::snprintf(hash, sizeof(hash), "%016llx", static_cast<unsigned long long>(s.state_hash));
    rows.push_back({"state hash", hash});
  }
  if (!s.alarm.empty()) rows.push_back({"alarm", s.alarm});
  if (!s.warning.empty()) rows.push_back({"warning", s.warning});
  PrintTable(rows, {}, out);
  if (s.passes.empty()) return;
  out << "\n";
  std::vector<std::vector<std::string>> passes = {{"pass", "last ms", "mean ms", "calls"}};
  double last = 0, mean = 0;
  for (const PassTiming& p : s.passes) {
    passes.push_back({p.name, Fixed(p.last_ms, 3), Fixed(p.mean_ms, 3), std::to_string(p.calls)});
    last += p.last_ms;
    mean += p.mean_ms;
  }
  passes.push_back({"total", Fixed(last, 3), Fixed(mean, 3), ""});
  PrintTable(passes, {1, 2, 3}, out);
}

void RunControl(Client& client, ControlVerb verb, uint32_t count, bool json, std::ostream& out) {
  ControlResult r;
  switch (verb) {
    case ControlVerb::kPause:
      r = client.Pause();
      break;
    case ControlVerb::kResume:
      r = client.Resume();
      break;
    case ControlVerb::kStep:
      r = client.Step(count);
      break;
    case ControlVerb::kStepBack:
      r = client.StepBack(count);
      break;
    case ControlVerb::kReset:
      r = client.Reset();
      break;
  }
  if (json) return PrintJson(ToJson(r), out);
  const ServerStatus& s = r.status;
  switch (verb) {
    case ControlVerb::kPause:
      out << "paused at " << Where(s) << "\n";
      break;
    case ControlVerb::kResume:
      out << s.state << " from " << Where(s) << "\n";
      break;
    case ControlVerb::kStep:
      out << "stepped " << r.frames_moved << " frame" << (r.frames_moved == 1 ? "" : "s") << " to "
          << Where(s) << ", " << s.state << "\n";
      break;
    case ControlVerb::kStepBack:
      out << "stepped back " << r.frames_moved << " frame" << (r.frames_moved == 1 ? "" : "s")
          << " to " << Where(s) << ", " << s.state;
      if (r.frames_moved < std::max(count, 1u)) out << " (no older frame is kept)";
      out << "\n";
      break;
    case ControlVerb::kReset:
      out << "reset to " << Where(s) << ", " << s.particles << " particles, " << s.state << "\n";
      break;
  }
}

void PrintParams(Client& client, bool json, std::ostream& out) {
  const std::vector<ParamInfo> params = client.GetParams();
  if (json) return PrintJson({{"params", ToJson(params)}}, out);
  std::vector<std::vector<std::string>> rows = {
      {"name", "value", "unit", "range", "default", "needs reset"}};
  for (const ParamInfo& p : params) {
    rows.push_back({p.name, Short(p.value), p.unit,
                    "[" + Short(p.min) + ", " + Short(p.max) + "]" + (p.integer ? " integer" : ""),
                    Short(p.default_value), p.needs_reset ? "yes" : ""});
  }
  PrintTable(rows, {1}, out);
}

std::vector<std::pair<std::string, double>> ParseAssignments(
    const std::vector<std::string>& assignments) {
  std::vector<std::pair<std::string, double>> values;
  std::set<std::string> seen;
  for (const std::string& assignment : assignments) {
    const size_t eq = assignment.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw UsageError("expected NAME=VALUE, got '" + assignment + "'");
    }
    const std::string name = assignment.substr(0, eq);
    const std::string text = assignment.substr(eq + 1);
    double value = 0;
    const char* end = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(text.data(), end, value);
    if (text.empty() || ec != std::errc() || ptr != end || !std::isfinite(value)) {
      throw UsageError(name + ": '" + text + "' is not a finite number");
    }
    if (!seen.insert(name).second) throw UsageError(name + ": given more than once");
    values.emplace_back(name, value);
  }
  if (values.empty()) throw UsageError("no NAME=VALUE given");
  return values;
}

void SetParams(Client& client, const std::vector<std::string>& assignments, bool json,
               std::ostream& out) {
  const std::vector<std::pair<std::string, double>> values = ParseAssignments(assignments);
  const UpdateResult r = client.UpdateParams(values);
  if (json) {
    Json changed = Json::object();
    for (const auto& [name, value] : values) {
      changed[name] = value;
      for (const ParamInfo& p : r.params) {
        if (p.name == name) changed[name] = p.value;
      }
    }
    return PrintJson({{"reset", r.reset},
                      {"changed", changed},
                      {"params", ToJson(r.params)},
                      {"status", ToJson(r.status)}},
                     out);
  }
  for (const auto& [name, value] : values) {
    const ParamInfo* info = nullptr;
    for (const ParamInfo& p : r.params) {
      if (p.name == name) info = &p;
    }
    out << name << " = " << Short(info ? info->value : value);
    if (info && !info->unit.empty()) out << " " << info->unit;
    out << "\n";
  }
  out << (r.reset ? "reset: the fluid was re-spawned, now at " + Where(r.status)
                  : "no reset: the simulation carries on at " + Where(r.status))
      << "\n";
}

void LoadScene(Client& client, const std::string& scene, const std::string& solver, bool json,
               std::ostream& out) {
  std::error_code error;
  const bool is_file = fs::is_regular_file(scene, error);
  ControlResult r;
  if (is_file) {
    std::ifstream file(scene, std::ios::binary);
    std::stringstream text;
    text << file.rdbuf();
    if (!file) throw std::runtime_error("cannot read " + scene);
    r = client.LoadSceneText(text.str(), solver);
  } else {
    r = client.LoadSceneByName(scene, solver);
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
    rows.push_back(
        {"sphere", "centre " + Point(o.center) + " m, radius " + Short(o.radius) + " m"});
  }
  for (const BoxObstacle& o : s.boxes) {
    rows.push_back({"box", Point(o.min) + " to " + Point(o.max) + " m"});
  }
  if (s.spheres.empty() && s.boxes.empty()) rows.push_back({"obstacles", "none"});
  rows.push_back({"version", std::to_string(s.scene_version)});
  PrintTable(rows, {}, out);
}

uint32_t ParseFields(const std::vector<std::string>& names) {
  uint32_t fields = codec::kPositions;
  for (const std::string& name : names) {
    if (name == "positions") {
      fields |= codec::kPositions;
    } else if (name == "speed") {
      fields |= codec::kSpeed;
    } else if (name == "velocity") {
      fields |= codec::kVelocity;
    } else if (name == "density") {
      fields |= codec::kDensity;
    } else {
      throw UsageError("--fields: unknown field '" + name +
                       "' (positions, speed, velocity, density)");
    }
  }
  return fields;
}

// ---------------------------------------------------------------------------------------------
// watch

void Watch(Client& client, const WatchOptions& options, std::ostream& out) {
  // Once, before the frames: what runs where (frames carry neither scene nor device).
  const ServerStatus status = client.GetStatus();
  if (!options.json) {
    out << "watching " << status.scene << " (solver " << status.solver << ") on "
        << DeviceText(status) << "\n"
        << std::flush;
  }
  std::unique_ptr<FrameStream> stream = client.StreamFrames(options.stream);
  WatchStats stats;
  const std::string address = client.address();
  size_t last_width = 0;
  auto print = [&] {
    const std::string line = stats.Line(address);
    if (options.live) {
      // Rewrite the line in place; blanks clear what a longer previous line left.
      out << "\r" << line
          << std::string(last_width > line.size() ? last_width - line.size() : 0, ' ')
          << std::flush;
      last_width = line.size();
    } else {
      out << line << std::endl;
    }
  };
  std::function<void()> tick;
  if (!options.json) tick = print;
  StreamWatchdog watchdog(*stream, options.interrupted, options.seconds,
                          options.live ? std::chrono::milliseconds(250) : std::chrono::seconds(1),
                          tick);

  FrameAssembler assembler;
  codec::Frame frame;
  FrameMessage message;
  uint64_t message_skips = 0;
  while (stream->Next(message)) {
    message_skips += message.frames_skipped;
    const FrameProgress progress = assembler.Add(message, frame);
    if (progress.decode_error) {
      std::lock_guard lock(stats.mutex);
      ++stats.decode_errors;
    }
    if (!progress.complete) continue;
    std::lock_guard lock(stats.mutex);
    ++stats.frames;
    stats.bytes += progress.frame_bytes;
    stats.frames_skipped = message_skips;
    const Clock::time_point now = Clock::now();
    stats.recent.push_back(now);
    stats.Trim(now);
    stats.have_frame = true;
    stats.frame = message.frame;
    stats.time = frame.time;
    stats.particles = frame.count;
    stats.frame_bytes = progress.frame_bytes;
    stats.latency_ms = progress.latency_ms;
  }
  watchdog.Stop();
  stream->Finish();  // throws unless the stream was ours to end

  const double seconds = std::chrono::duration<double>(Clock::now() - stats.start).count();
  std::lock_guard lock(stats.mutex);
  const double rate = seconds > 0 ? double(stats.frames) / seconds : 0;
  const double per_frame = stats.frames ? double(stats.bytes) / double(stats.frames) : 0;
  if (options.json) {
    return PrintJson({{"frames", stats.frames},
                      {"seconds", seconds},
                      {"frames_per_second", rate},
                      {"bytes", stats.bytes},
                      {"bytes_per_frame", per_frame},
                      {"last_frame", stats.frame},
                      {"time", stats.time},
                      {"particles", stats.particles},
                      {"frames_skipped", stats.frames_skipped},
                      {"decode_errors", stats.decode_errors},
                      {"device", status.device}},
                     out);
  }
  if (options.live) out << "\n";
  out << "watched " << Fixed(seconds, 1) << " s: " << stats.frames << " frames (" << Fixed(rate, 1)
      << " frames/s), " << HumanBytes(per_frame) << "/frame";
  if (stats.frames_skipped) out << ", " << stats.frames_skipped << " skipped";
  if (stats.decode_errors) out << ", " << stats.decode_errors << " decode errors";
  out << "\n";
}

// ---------------------------------------------------------------------------------------------
// record

namespace {

std::vector<char> FloatBytes(const std::vector<float>& values) {
  std::vector<char> bytes(values.size() * sizeof(float));
  if (!bytes.empty()) std::memcpy(bytes.data(), values.data(), bytes.size());
  return bytes;
}

VtpPoints ToVtp(const codec::Frame& frame) {
  VtpPoints points;
  points.positions = frame.positions;
  std::vector<uint32_t> ids(frame.count);
  for (uint32_t k = 0; k < frame.count; ++k) ids[k] = k * frame.stride;
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
  uint32_t count = 0;  // N
  uint32_t stride = 1;
  uint32_t fields = 0;
  std::vector<float> positions, speed, velocity, density;
  std::vector<double> time;
  std::vector<uint64_t> step, frame;

  // Returns why the frame cannot join the others, or "".
  std::string Append(const codec::Frame& f, uint64_t frame_number) {
    if (time.empty()) {
      count = f.count, stride = f.stride, fields = f.fields;
    } else if (f.count != count || f.fields != fields) {
      return "the frame changed from " + std::to_string(count) + " particles (" +
             FieldNames(fields) + ") to " + std::to_string(f.count) + " (" + FieldNames(f.fields) +
             ") at frame " + std::to_string(frame_number) + " (a reset or a new scene?)";
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
    std::vector<uint32_t> ids(n);
    for (uint32_t k = 0; k < n; ++k) ids[k] = k * stride;
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
  const fs::path parent = path.parent_path();
  if (!parent.empty() && !fs::is_directory(parent)) {
    throw std::runtime_error("cannot write " + options.out + ": no directory " + parent.string());
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
  while (got < options.frames && stream->Next(message)) {
    const FrameProgress progress = assembler.Add(message, frame);
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
