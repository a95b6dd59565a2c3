// The fault and soak suite, long mode: the cases of tests/soak/soak_cases.h at the sizes
// (10,000 mixed RPCs from 4 threads, 100 subscribe/disconnect cycles and 64 subscribers with the
// 65th refused, 10 stalled readers for 60 s, the hostile scenes 10 times, SIGTERM under load,
// 100 clients killed mid-stream), against a real dysa-server, with the same bounds as
// ctest -L soak. Prints each case's figures and writes bench/results/soak.csv; the exit status is
// 1 if any case broke a bound (the line says which).
//
//   build/release/bench/soak_bench [--case REGEX] [--out bench/results]
//                                  [--server build/release/server/service/dysa-server]
//                                  [--cli build/release/clients/cli/dysa]
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>
#include <string>
#include <vector>

#include "soak/soak_cases.h"

int main(int argc, char** argv) {
  using namespace dysa::soak;
  CLI::App app{"The fault and soak suite at the issue's sizes, against a real dysa-server"};
  std::string case_regex = ".*", out_dir = "bench/results";
  SoakEnv env{DYSA_SERVER_BINARY, DYSA_BINARY, {}};
  app.add_option("--case", case_regex, "Only the cases whose name matches this regex (search)")
      ->capture_default_str();
  app.add_option("--out", out_dir, "Directory for soak.csv")->capture_default_str();
  app.add_option("--server", env.server_binary, "dysa-server")->capture_default_str();
  app.add_option("--cli", env.cli_binary, "dysa (the client killed mid-stream)")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  env.work_dir =
      std::filesystem::temp_directory_path() / ("dysa_soak_bench_" + std::to_string(::getpid()));
  std::filesystem::create_directories(env.work_dir);
  const std::vector<std::pair<std::string, std::function<SoakResult()>>> cases = {
      {"rpc_soak", [&] { return RpcSoak(env, {.rpcs = 10000, .threads = 4}); }},
      {"subscriber_churn", [&] { return SubscriberChurn(env, {.cycles = 100, .cap = 64}); }},
      {"stalled_readers", [&] { return StalledReaders(env, {.readers = 10, .seconds = 60}); }},
      {"hostile_scenes", [&] { return HostileScenes(env, {.rounds = 10}); }},
      {"sigterm_under_load",
       [&] { return SigtermUnderLoad(env, {.streams = 10, .rpc_threads = 4, .load_seconds = 5}); }},
      {"client_killed_mid_stream", [&] { return ClientKilledMidStream(env, {.cycles = 100}); }},
  };
  const std::regex filter(case_regex);
  std::vector<SoakResult> results;
  for (const auto& [name, run] : cases) {
    if (!std::regex_search(name, filter)) continue;
    const auto start = std::chrono::steady_clock::now();
    results.push_back(run());
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const SoakResult& r = results.back();
    std::printf("%-26s %s  (%.1f s)  %s\n", name.c_str(), r.ok() ? "ok  " : "FAIL", seconds,
                r.Summary().c_str());
    for (const std::string& failure : r.failures) std::printf("    %s\n", failure.c_str());
    std::fflush(stdout);
  }
  std::filesystem::remove_all(env.work_dir);
  if (results.empty()) {
    std::fprintf(stderr, "soak_bench: no case matches --case '%s'\n", case_regex.c_str());
    return 2;
  }
  std::filesystem::create_directories(out_dir);
  const std::filesystem::path csv = std::filesystem::path(out_dir) / "soak.csv";
  std::ofstream out(csv);
  out << "case,figure,value,unit,ok\n";
  bool ok = true;
  for (const SoakResult& r : results) {
    ok &= r.ok();
    for (const Figure& f : r.figures) {
      out << r.case_name << "," << f.name << "," << f.value << "," << f.unit << ","
          << (r.ok() ? 1 : 0) << "\n";
    }
  }
  std::printf("wrote %s\n", csv.string().c_str());
  return ok ? 0 : 1;
}
