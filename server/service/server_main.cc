// dysa-server: runs a scene and serves dysa.v1.Simulation. Argument parsing and wiring only.
//
// Phases: parse flags -> read files (scene, token, TLS) -> take SIGINT/SIGTERM from every thread
// -> start host and server -> wait for a signal -> shut down in reverse order, within
// kShutdownBound of the signal.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <sstream>

#include "dysa/core/device.h"
#include "dysa/core/scene.h"
#include "dysa/core/types.h"
#include "dysa/service/server.h"
#include "dysa/service/shutdown_signal.h"
#include "dysa/service/simulation_host.h"
#ifdef DYSA_WITH_MPI
#include "server_ranks.h"
#endif

namespace {

// From SIGTERM to exit, whatever runs (a long Step, a step of a pathological scene, streams to
// stalled readers): well inside a container's grace period. The orderly shutdown gets all but
// kExitMargin of it; the rest is for the exit itself.
constexpr auto kShutdownBound = std::chrono::milliseconds(1500);
constexpr auto kExitMargin = std::chrono::milliseconds(300);

// "2026-11-22T10:00:00.123Z dysa-server: <line>" on stderr; whole lines from any thread.
void Log(const std::string& line) {
  static std::mutex mu;
  const auto now = std::chrono::system_clock::now();
  const std::time_t seconds = std::chrono::system_clock::to_time_t(now);
  const int ms = int(
      std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000);
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char stamp[40];
  std::strftime(stamp, sizeof(stamp), "%Y-%m-%dT%H:%M:%S", &utc);
  std::lock_guard lock(mu);
  std::fprintf(stderr, "%s.%03dZ dysa-server: %s\n", stamp, ms, line.c_str());
  std::fflush(stderr);
}

std::string ReadFile(const std::string& path, const std::string& flag) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(flag + ": cannot read '" + path + "'");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string ReadToken(const std::string& path) {
  std::string token = ReadFile(path, "--token-file");
  const auto end = token.find_last_not_of(" \t\r\n");
  token.erase(end == std::string::npos ? 0 : end + 1);
  token.erase(0, token.find_first_not_of(" \t\r\n"));
  if (token.empty()) throw std::runtime_error("--token-file: '" + path + "' holds no token");
  if (token.find_first_of(" \t\r\n") != std::string::npos) {
    throw std::runtime_error("--token-file: the token must be one word without spaces");
  }
  return token;
}

// Written then renamed, so a reader polling for the file never sees a partial number.
void WritePortFile(const std::string& path, int port) {
  const std::string partial = path + ".partial";
  {
    std::ofstream out(partial);
    out << port << "\n";
    if (!out) throw std::runtime_error("--port-file: cannot write '" + path + "'");
  }
  std::filesystem::rename(partial, path);
}

}  // namespace

int main(int argc, char** argv) {
  // Phase 1: flags.
  CLI::App app{"dysa-server: runs a DySAQUASIMs simulation and serves it over gRPC"};
  std::string scene_arg = "seed_test_scene";
  std::string device_arg = "cpu";
  std::string listen = "127.0.0.1:50051";
  int threads = 0;
  double frame_rate = 60;
  double balance_threshold = 1.1;  // under mpirun: balancer.h's threshold
  double rank_timeout = 30;        // s, under mpirun: a collective's wait for a hung rank
  uint64_t history_frames = 600;
  uint64_t history_mib = 256;
  std::string token_file, tls_cert, tls_key, port_file;
  bool protect_watch = false;
  bool paused = false;
  uint64_t max_particles = dysa::kMaxStreamedParticles;
  size_t max_subscribers = 64;
  app.add_option("--scene", scene_arg, "Built-in scene name or scene JSON file")
      ->capture_default_str();
  app.add_option("--listen", listen, "ADDR:PORT to listen on (port 0: any free port)")
      ->capture_default_str();
  app.add_option("--threads", threads, "OpenMP threads for the solver (default: all cores)")
      ->check(CLI::Range(1, 1024));
  app.add_option("--device", device_arg,
                 "Where the simulation steps: cpu (OpenMP), cuda (= cuda:0) or cuda:N, a CUDA GPU "
                 "(scenes whose solver has no GPU backend are refused). Under mpirun each rank "
                 "steps on a GPU: cuda maps a host's ranks to its GPUs by local rank, cuda:N puts "
                 "all on N (wcsph, seed and dfsph)")
      ->capture_default_str();
  app.add_option("--frame-rate", frame_rate,
                 "Frames simulated per wall second at most; 0: as fast as possible")
      ->check(CLI::Range(0.0, 10000.0))
      ->capture_default_str();
  app.add_option("--history-frames", history_frames, "Frames StepBack can reach")
      ->check(CLI::Range(uint64_t{1}, uint64_t{1000000}))
      ->capture_default_str();
  app.add_option("--history-mib", history_mib, "Memory for the step-back history, MiB")
      ->check(CLI::Range(uint64_t{1}, uint64_t{1} << 20))
      ->capture_default_str();
  auto* token_opt = app.add_option("--token-file", token_file,
                                   "File holding a token; control RPCs then need "
                                   "'authorization: Bearer <token>'")
                        ->check(CLI::ExistingFile);
  app.add_flag("--protect-watch", protect_watch,
               "With --token-file: watching (status, params, scenes, frames) needs the token too")
      ->needs(token_opt);
  auto* cert_opt = app.add_option("--tls-cert", tls_cert, "PEM certificate chain: serve TLS")
                       ->check(CLI::ExistingFile);
  auto* key_opt = app.add_option("--tls-key", tls_key, "PEM private key of --tls-cert")
                      ->check(CLI::ExistingFile);
  cert_opt->needs(key_opt);
  key_opt->needs(cert_opt);
  app.add_option("--max-particles", max_particles,
                 "Refuse scenes and parameters with more particles (RESOURCE_EXHAUSTED); above "
                 "20,000,000 (a frame's limit) only streams with a budget can watch")
      ->check(CLI::Range(uint64_t{1}, uint64_t{dysa::kMaxParticles}))
      ->capture_default_str();
  app.add_option("--balance-threshold", balance_threshold,
                 "Under mpirun: move the slab cuts when max/mean of the ranks' step times, over "
                 "10 steps, exceeds this")
      ->check(CLI::Range(1.0, 1e6))
      ->capture_default_str();
  app.add_option("--rank-timeout", rank_timeout,
                 "Under mpirun: seconds a rank waits for the others in one collective before it "
                 "ends the job (one of them hangs)")
      ->check(CLI::Range(0.1, 1e6))
      ->capture_default_str();
  app.add_option("--max-subscribers", max_subscribers, "Frame streams open at once at most")
      ->check(CLI::Range(size_t{1}, size_t{100000}))
      ->capture_default_str();
  app.add_option("--port-file", port_file, "Write the port listened on to this file");
  app.add_flag("--paused", paused, "Start paused");
  CLI11_PARSE(app, argc, argv);

#ifdef DYSA_WITH_MPI
  const bool on_ranks = dysa::service::LaunchedByMpirun();
#else
  const bool on_ranks = false;
#endif

  // Phase 2: inputs. Every error here names its flag or field and exits 2.
  dysa::service::HostOptions host_options;
  dysa::service::ServerOptions server_options;
  dysa::Scene scene;
  try {
    try {
      host_options.device = dysa::ParseDevice(device_arg);
      // Refuses to start without the GPU, naming what is missing (driver, GPU, ordinal, build).
      // Under mpirun each rank's GPU is its own (by local rank) and all ranks learn together
      // whether every one can use its GPU, once MPI runs (ServerRanks), so that none exits alone.
      if (!on_ranks) dysa::QueryDevice(host_options.device);
    } catch (const dysa::ConfigError& e) {
      throw std::runtime_error("--device " + device_arg + ": " + e.message());
    }
    scene = dysa::LoadScene(scene_arg);
    if (!token_file.empty()) server_options.token = ReadToken(token_file);
    if (!tls_cert.empty()) {
      server_options.tls_cert_pem = ReadFile(tls_cert, "--tls-cert");
      server_options.tls_key_pem = ReadFile(tls_key, "--tls-key");
    }
  } catch (const std::exception& e) {
    std::cerr << "dysa-server: error: " << e.what() << "\n";
    return 2;
  }
  host_options.solver_threads = threads;
  host_options.frame_rate = frame_rate;
  host_options.history.frames = history_frames;
  host_options.history.max_bytes = size_t(history_mib) << 20;
  host_options.max_particles = max_particles;
  host_options.max_subscribers = max_subscribers;
  host_options.start_paused = paused;
  host_options.log = Log;
  server_options.listen = listen;
  server_options.protect_watch = protect_watch;

  // Phase 3: signals. Blocked before any thread starts, so every thread inherits the mask and
  // only the signal thread receives them (from here on, also during start-up). MPI's own
  // threads, started next, too.
  dysa::service::ShutdownSignal signals(kShutdownBound, Log);

#ifdef DYSA_WITH_MPI
  // Under mpirun: rank 0 serves and steps on every rank (server_ranks.h); the others serve its
  // commands until it stops them (or end within kShutdownBound of a signal).
  std::unique_ptr<dysa::service::ServerRanks> ranks;
  if (on_ranks) {
    try {
      ranks = std::make_unique<dysa::service::ServerRanks>(&argc, &argv, balance_threshold,
                                                           rank_timeout, device_arg);
    } catch (const std::exception& e) {
      std::cerr << "dysa-server: error: " << e.what() << "\n";
      return 1;
    }
    if (!ranks->device_error().empty()) {
      // Some rank cannot use its GPU: every rank knows it (ServerRanks); rank 0 says why.
      if (ranks->rank() == 0) {
        std::cerr << "dysa-server: error: --device " << device_arg << ": " << ranks->device_error()
                  << "\n";
      }
      return 2;
    }
    if (ranks->rank() != 0) return ranks->Serve(threads, Log);
    host_options.backend = ranks->backend();
    // Rank 0's own GPU (its simulation thread waits on it and gathers frames).
    host_options.device = ranks->device();
    Log("rank 0 of " + std::to_string(ranks->size()) + ": stepping on every rank" +
        (host_options.device.is_cuda() ? ", each on its GPU" : ""));
  }
#endif

  // Phase 4: run.
  std::unique_ptr<dysa::service::SimulationHost> host;
  std::unique_ptr<dysa::service::Server> server;
  try {
    host = std::make_unique<dysa::service::SimulationHost>(std::move(scene), host_options);
    server = std::make_unique<dysa::service::Server>(*host, server_options);
    if (!port_file.empty()) WritePortFile(port_file, server->port());
  } catch (const dysa::ConfigError& e) {
    // The scene's solver has no backend on --device (or the GPU failed as it was set up): a
    // usage error, as in phase 2. Others (--max-particles) as before.
    if (e.field() != "device") {
      std::cerr << "dysa-server: error: " << e.what() << "\n";
      return 1;
    }
    std::cerr << "dysa-server: error: --device " << device_arg << ": " << e.message() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "dysa-server: error: " << e.what() << "\n";
    return 1;
  }
  const std::string address = listen.substr(0, listen.rfind(':'));
  Log("listening on " + address + ":" + std::to_string(server->port()) +
      (server_options.tls_cert_pem.empty() ? "" : " (TLS)") +
      (server_options.token.empty()
           ? ""
           : (protect_watch ? ", token for every call" : ", token for controls")) +
      ", " + std::to_string(host->Status().solver_threads) +
      (host->Status().solver_threads == 1 ? " solver thread" : " solver threads") + " on " +
      host->Status().device);

  Log("received " + signals.Wait() + ", shutting down");

  // Phase 5: cleanup, in reverse order.
  if (!server->Shutdown(signals.deadline() - kExitMargin)) {
    // The host cannot be destroyed while its thread is inside the step.
    Log("the simulation thread is still inside a solver step: exiting without waiting for it");
    std::_Exit(0);
  }
  server.reset();
  host.reset();
  signals.Disarm();
  Log("stopped");
  return 0;
}
