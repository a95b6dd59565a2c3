// dysa status: the server's status as a table (and its passes' timings) or JSON.
#include <cstdio>
#include <ostream>
#include <string>
#include <vector>

#include "remote_commands.h"
#include "remote_format.h"

namespace dysa::remote {

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
  if (!s.streams.empty()) {
    out << "\n";
    std::vector<std::vector<std::string>> streams = {
        {"stream", "detail", "particles", "frames/s", "delivered/s", "age ms", "budget"}};
    for (size_t i = 0; i < s.streams.size(); ++i) {
      const StreamStatus& t = s.streams[i];
      std::string budget;
      if (t.fps_target > 0) budget += Short(t.fps_target) + " fps ";
      if (t.byte_budget > 0) budget += HumanBytes(double(t.byte_budget)) + "/s ";
      if (t.particle_budget > 0) budget += std::to_string(t.particle_budget) + " particles";
      streams.push_back({std::to_string(i + 1), Fixed(t.detail, 3), std::to_string(t.particles),
                         Fixed(t.frames_per_second, 1), HumanBytes(t.bytes_per_second),
                         Fixed(1000 * t.age_s, 0), budget.empty() ? "-" : budget});
    }
    PrintTable(streams, {1, 2, 3, 4, 5}, out);
  }
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

}  // namespace dysa::remote
