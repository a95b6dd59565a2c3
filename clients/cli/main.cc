// dysa: the DySAQUASIMs command line. Argument parsing and wiring only.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <iostream>
#include <sstream>

#include "dysa/core/device.h"
#include "dysa/core/params.h"
#include "dysa/core/scene.h"
#include "dysa/core/solver.h"
#include "dysa/core/text.h"
#include "dysa/core/types.h"
#include "run_command.h"
#include "run_distributed.h"
#include "validate_command.h"

#ifdef DYSA_WITH_MPI
#include <memory>

#include "dysa/distributed/rank_device.h"
#include "mpi_communicator.h"
#endif

#ifdef DYSA_WITH_REMOTE
#include <atomic>
#include <chrono>
#include <csignal>
#include <functional>
#include <optional>
#include <utility>
#include <vector>

#include "dysa/client/client.h"
#include "remote_commands.h"
#endif

namespace {

std::string ParameterHelp() {
  std::string text =
      "Parameters for --set (name, range, default, the solvers that read it; the others ignore "
      "it):\n";
  for (const dysa::ParamDecl& p : dysa::ParamTable()) {
    std::ostringstream line;
    line << "  " << p.name << "  " << p.RangeText() << ", default " << p.DefaultValue()
         << (p.needs_reset ? ", re-spawns the fluid" : "") << ", read by " << p.SolversText()
         << "\n      " << p.description << "\n";
    text += line.str();
  }
  text += "Built-in scenes:";
  for (const std::string& name : dysa::BuiltinSceneNames()) text += " " + name;
  text += "\nSolvers:";
  for (const dysa::SolverInfo& s : dysa::SolverRegistry()) text += " " + std::string(s.name);
  return text + "\n";
}

constexpr const char* kDeviceHelp =
    "Where the steps run: cpu (default; OpenMP), cuda (= cuda:0) or cuda:N, a CUDA GPU (for the "
    "solvers with a GPU backend)";

// --device: cpu, cuda or cuda:N, as dysa::ParseDevice reads them; anything else is a usage error
// naming the flag and the accepted forms.
CLI::Validator DeviceValidator() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        try {
          dysa::ParseDevice(text);
          return "";
        } catch (const dysa::ConfigError& e) {
          return e.message();
        }
      },
      "cpu|cuda[:N]");
}

// --set NAME=VALUE of `dysa run` and `dysa validate`: a malformed assignment or a value a double
// cannot hold is a usage error (2), as for `dysa set`; the name and the range are checked when
// the run starts (1, as the server's check of `dysa set`).
CLI::Validator AssignmentValidator() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        try {
          dysa::ParseAssignment(text);
          return "";
        } catch (const dysa::ConfigError& e) {
          return e.what();
        }
      },
      "NAME=VALUE");
}

// `dysa WORD` with no command WORD: CLI11 would only say that a command is required.
int UnknownCommand(CLI::App& app) {
  std::string commands;
  for (const CLI::App* command : app.get_subcommands([](CLI::App*) { return true; })) {
    commands += (commands.empty() ? "" : ", ") + command->get_name();
  }
  std::cerr << "dysa: error: unknown command '" << dysa::SafeText(app.remaining().front())
            << "'; the commands are " << commands << " (dysa --help)\n";
  return 2;
}

// An error of `dysa run` or `dysa validate`; a device that cannot run (no GPU, no driver, a build
// without CUDA, a solver without a GPU backend) is a usage error (2), naming --device.
int ReportError(const std::string& command, const std::exception& error, const std::string& device,
                int status) {
  const auto* config = dynamic_cast<const dysa::ConfigError*>(&error);
  if (config && config->field() == "device") {
    std::cerr << "dysa " << command << ": error: --device " << device << ": " << config->message()
              << "\n";
    return 2;
  }
  std::cerr << "dysa " << command << ": error: " << error.what() << "\n";
  return status;
}

#ifdef DYSA_WITH_MPI
constexpr const char* kMpiRunHelp =
    "\n\nUnder mpirun (mpirun -np N dysa run SCENE) the run is spread over the N ranks "
    "(docs/distributed.md): wcsph, seed and dfsph, on the CPU or with --device cuda, each rank "
    "on GPU local_rank % GPUs (cuda:N: all on N).";

// `dysa run` under mpirun. Every rank parsed the same arguments, so a ConfigError is the same on
// every rank: rank 0 reports it and all exit together. Any other error may be one rank's alone
// while the others wait in a collective: that rank aborts the whole job.
int RunOnRanks(int argc, char** argv, const dysa::RunOptions& run, const std::string& device) {
  dysa::distributed::MpiSession session(&argc, &argv);
  const dysa::distributed::MpiCommunicator comm({.wait_limit_s = run.rank_timeout});
  try {
    // GPU ranks: --device cuda (no index) spreads a host's ranks over its GPUs by local rank.
    dysa::RunOptions options = run;
    if (options.device.is_cuda()) {
      options.device = dysa::distributed::DeviceOfRank(device, dysa::distributed::LocalRank(),
                                                       dysa::CudaDeviceCount());
    }
    dysa::RunDistributed(options, comm, std::cout);
  } catch (const dysa::ConfigError& e) {
    // As RunOffline's errors: 2 for --device, 1 for a scene or parameter.
    const int status = e.field() == "device" ? 2 : 1;
    if (comm.rank() == 0) ReportError("run", e, device, status);
    return status;
  } catch (const dysa::CollectiveError& e) {
    if (comm.rank() == 0) std::cerr << "dysa run: error: " << e.what() << "\n";
    return 1;
  } catch (const std::invalid_argument& e) {
    if (comm.rank() == 0) std::cerr << "dysa run: error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "dysa run: error on rank " << comm.rank() << ": " << e.what() << "\n";
    comm.Abort(1);
  }
  return 0;
}
#else
constexpr const char* kMpiRunHelp = "";
#endif

#ifdef DYSA_WITH_REMOTE

namespace remote = dysa::remote;

std::atomic<bool> g_interrupted{false};

// Ctrl-C during watch or record: the command cancels its stream and ends cleanly. A second
// Ctrl-C kills the process as usual.
extern "C" void OnInterrupt(int) {
  g_interrupted = true;
  std::signal(SIGINT, SIG_DFL);
}

// The network verbs: their CLI11 subcommands and, for the one parsed, what to run.
class RemoteCommands {
 public:
  explicit RemoteCommands(CLI::App& app) {
    app.add_option("--server", connect_.address,
                   "Server address HOST:PORT (environment: DYSA_SERVER)")
        ->envname("DYSA_SERVER")
        ->capture_default_str();
    app.add_option("--token", connect_.token,
                   "Access token, sent as 'authorization: Bearer T' (environment: DYSA_TOKEN)")
        ->envname("DYSA_TOKEN");
    app.add_option("--tls-ca", connect_.tls_ca_file,
                   "Connect with TLS, trusting this PEM CA certificate (default: plaintext)")
        ->check(CLI::ExistingFile);
    app.add_option("--tls-name", connect_.tls_server_name,
                   "The name on the server's certificate, when not the address's host");
    app.add_option("--timeout", timeout_,
                   "Seconds to wait for an answer (default: 30 for queries, 300 for controls, "
                   "which may simulate)")
        ->check(CLI::Range(0.001, 1e6));
    app.add_flag("--json", json_, "Print one JSON object instead of text");

    Add(app, "status", "Server and simulation status, with per-pass timings",
        [this](remote::Client& c) { remote::PrintStatus(c, json_, std::cout); });
    Add(app, "pause", "Pause the simulation", [this](remote::Client& c) {
      remote::RunControl(c, remote::ControlVerb::kPause, 0, json_, std::cout);
    });
    Add(app, "resume", "Resume the simulation", [this](remote::Client& c) {
      remote::RunControl(c, remote::ControlVerb::kResume, 0, json_, std::cout);
    });
    CLI::App* step =
        Add(app, "step", "Advance N frames (default 1), then pause", [this](remote::Client& c) {
          remote::RunControl(c, remote::ControlVerb::kStep, count_, json_, std::cout);
        });
    step->add_option("N", count_, "Frames")->check(CLI::Range(1u, remote::kMaxStepFrames));
    CLI::App* back =
        Add(app, "back", "Go back N frames (default 1) in the history, then pause",
            [this](remote::Client& c) {
              remote::RunControl(c, remote::ControlVerb::kStepBack, count_, json_, std::cout);
            });
    back->add_option("N", count_, "Frames")->check(CLI::Range(1u, remote::kMaxStepFrames));
    Add(app, "reset", "Re-spawn the fluid of the current scene; time goes to 0",
        [this](remote::Client& c) {
          remote::RunControl(c, remote::ControlVerb::kReset, 0, json_, std::cout);
        });
    Add(app, "params",
        "Every parameter: value, unit, range, default, whether it needs a reset, the solvers that "
        "read it",
        [this](remote::Client& c) { remote::PrintParams(c, json_, std::cout); });
    CLI::App* set =
        Add(app, "set", "Change parameters, all or nothing (see `dysa params`)",
            [this](remote::Client& c) { remote::SetParams(c, assignments_, json_, std::cout); });
    set->add_option("NAME=VALUE", assignments_, "Parameters to change")->required();
    CLI::App* load =
        Add(app, "load", "Load a scene: a built-in name (see `dysa scenes`) or a scene JSON file",
            [this](remote::Client& c) { remote::LoadScene(c, scene_, solver_, json_, std::cout); });
    load->add_option("SCENE", scene_, "Scene name or file")->required();
    load->add_option("--solver", solver_,
                     "Run the scene with this registered solver instead of its own (see `dysa "
                     "scene`)");
    Add(app, "scenes", "The built-in scenes; * marks the current one",
        [this](remote::Client& c) { remote::PrintScenes(c, json_, std::cout); });
    Add(app, "scene",
        "The running scene: solver and the registered ones, domain, obstacles, particle radius",
        [this](remote::Client& c) { remote::PrintScene(c, json_, std::cout); });

    CLI::App* watch = Add(app, "watch", "Stream frames and show a live status line (until Ctrl-C)",
                          [this](remote::Client& c) {
                            remote::WatchOptions options;
                            options.stream = Stream();
                            options.camera = Camera();
                            options.seconds = seconds_;
                            options.live = isatty(STDOUT_FILENO) != 0;
                            options.json = json_;
                            options.interrupted = &g_interrupted;
                            remote::Watch(c, options, std::cout);
                          });
    watch->add_option("--seconds", seconds_, "Stop after S seconds (default: until Ctrl-C)")
        ->check(CLI::Range(0.001, 1e9));
    AddStreamOptions(watch);

    CLI::App* record =
        Add(app, "record", "Record N frames to a ParaView series (vtk) or a NumPy .npz file",
            [this](remote::Client& c) {
              record_.stream = Stream();
              record_.camera = Camera();
              record_.json = json_;
              record_.progress = isatty(STDERR_FILENO) != 0;
              record_.interrupted = &g_interrupted;
              remote::Record(c, record_, std::cout, std::cerr);
            });
    record->add_option("--frames", record_.frames, "Frames to record")
        ->required()
        ->check(CLI::Range(uint64_t{1}, uint64_t{100'000'000}));
    record
        ->add_option("--out", record_.out,
                     "npz: the file; vtk: OUT.pvd and OUT/frame_NNNNNN.vtp (OUT may end in .pvd)")
        ->required();
    record
        ->add_option("--format", record_.format,
                     "vtk or npz (default: npz when OUT ends in .npz, else vtk)")
        ->check(CLI::IsMember({"vtk", "npz"}));
    AddStreamOptions(record);
  }

  // Runs the parsed verb, if one was; returns its exit status.
  std::optional<int> Run() {
    for (const auto& [cmd, action] : commands_) {
      if (!cmd->parsed()) continue;
      const std::string prefix = "dysa " + cmd->get_name() + ": error: ";
      try {
        if (timeout_ > 0) {
          const auto deadline = std::chrono::milliseconds(int64_t(timeout_ * 1000));
          connect_.query_deadline = connect_.control_deadline = deadline;
        }
        remote::Client client(connect_);
        if (cmd->get_name() == "watch" || cmd->get_name() == "record") {
          std::signal(SIGINT, OnInterrupt);
        }
        action(client);
        return 0;
      } catch (const remote::UsageError& e) {
        std::cerr << prefix << e.what() << "\n";
        return 2;
      } catch (const std::exception& e) {
        std::cerr << prefix << e.what() << "\n";
        return 1;
      }
    }
    return std::nullopt;
  }

 private:
  CLI::App* Add(CLI::App& app, const std::string& name, const std::string& description,
                std::function<void(remote::Client&)> action) {
    CLI::App* cmd = app.add_subcommand(name, description);
    // Global options (--server, --json, ...) may also follow the verb.
    cmd->fallthrough();
    commands_.emplace_back(cmd, std::move(action));
    return cmd;
  }

  void AddStreamOptions(CLI::App* cmd) {
    cmd->add_option("--fields", fields_,
                    "Fields besides positions: speed, velocity, density (default: speed)")
        ->delimiter(',')
        ->check(CLI::IsMember({"positions", "speed", "velocity", "density"}));
    cmd->add_option("--stride", stride_, "Only the particles with id % K == 0")
        ->check(CLI::Range(1u, 1u << 30));
    cmd->add_option("--max-fps", max_fps_, "At most F frames per second (default: every frame)")
        ->check(CLI::Range(0.0, 1e6));
    cmd->add_option("--fps-target", fps_target_,
                    "Hold F frames per second on this link: the server sends the largest "
                    "stable, even subset of the particles that fits (also caps the frame rate)")
        ->check(CLI::Range(0.001, 1000.0));
    cmd->add_option("--byte-budget", byte_budget_,
                    "With --fps-target: at most B bytes per second (>= 1000)")
        ->check(CLI::Range(uint64_t{1000}, uint64_t{1} << 50));
    cmd->add_option("--particle-budget", particle_budget_,
                    "At most P particles per frame (a stable, even subset)")
        ->check(CLI::Range(1u, 20000000u));
    cmd->add_option("--view", view_,
                    "With a budget: the camera EX,EY,EZ,TX,TY,TZ[,FOV] (eye and target in m, "
                    "vertical field of view in degrees, default 45): the particles in view first")
        ->delimiter(',')
        ->expected(6, 7);
    cmd->add_option("--velocity-encoding", velocity_encoding_,
                    "With velocity: components (the tightest bound per component) or octahedral "
                    "(|v| and direction, an error relative to the speed)")
        ->check(CLI::IsMember({"components", "octahedral"}));
  }

  // The --view camera, if given. Throws UsageError for a wrong count of numbers (the server
  // checks the ranges and names the field).
  std::optional<remote::StreamCamera> Camera() const {
    if (view_.empty()) return std::nullopt;
    if (view_.size() != 6 && view_.size() != 7) {
      throw remote::UsageError(
          "--view: 6 or 7 numbers: eye x,y,z and target x,y,z (m), then optionally the vertical "
          "field of view (degrees)");
    }
    remote::StreamCamera camera;
    camera.eye = {view_[0], view_[1], view_[2]};
    camera.target = {view_[3], view_[4], view_[5]};
    if (view_.size() == 7) camera.fov_y_deg = view_[6];
    return camera;
  }

  remote::StreamOptions Stream() const {
    remote::StreamOptions stream;
    stream.fields =
        remote::ParseFields(fields_.empty() ? std::vector<std::string>{"speed"} : fields_);
    stream.stride = stride_;
    stream.max_fps = max_fps_;
    if (byte_budget_ > 0 && fps_target_ == 0) {
      throw remote::UsageError(
          "--byte-budget: needs --fps-target (bytes per second are spread over the target frame "
          "rate)");
    }
    stream.fps_target = fps_target_;
    stream.byte_budget = byte_budget_;
    stream.particle_budget = particle_budget_;
    stream.velocity_encoding = velocity_encoding_ == "octahedral"
                                   ? dysa::codec::VelocityEncoding::kOctahedral
                                   : dysa::codec::VelocityEncoding::kComponents;
    return stream;
  }

  remote::ConnectOptions connect_;
  double timeout_ = 0;
  bool json_ = false;
  uint32_t count_ = 1;
  std::vector<std::string> assignments_;
  std::string scene_;
  std::string solver_;
  double seconds_ = 0;
  std::vector<std::string> fields_;
  uint32_t stride_ = 0;
  double max_fps_ = 0;
  double fps_target_ = 0;
  uint64_t byte_budget_ = 0;
  uint32_t particle_budget_ = 0;
  std::string velocity_encoding_ = "components";
  std::vector<double> view_;
  remote::RecordOptions record_;
  std::vector<std::pair<CLI::App*, std::function<void(remote::Client&)>>> commands_;
};

#endif  // DYSA_WITH_REMOTE

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"dysa: DySAQUASIMs fluid simulation command line"};
  app.require_subcommand(1);

  dysa::RunOptions run;
  double end_time = 0;
  uint64_t steps = 0;
  CLI::App* run_cmd = app.add_subcommand(
      "run", "Simulate a scene offline (no server): progress, per-pass timings, probes.csv, VTK");
  run_cmd->add_option("scene", run.scene, "Built-in scene name or path to a scene JSON file")
      ->required();
  run_cmd->add_option("--set", run.sets, "Override a parameter, NAME=VALUE (repeatable)")
      ->check(AssignmentValidator());
  auto* end_opt = run_cmd
                      ->add_option("--end-time", end_time,
                                   "Simulated seconds to run (default: the scene's end_time)")
                      ->check(CLI::Range(1e-9, 1e6));
  auto* steps_opt =
      run_cmd->add_option("--steps", steps, "Number of solver steps to run instead of --end-time")
          ->check(CLI::Range(uint64_t{1}, uint64_t{1} << 40));
  end_opt->excludes(steps_opt);
  run_cmd->add_option("--threads", run.threads, "OpenMP threads (default: all cores)")
      ->check(CLI::Range(1, 1024));
  std::string run_device = "cpu";
  run_cmd->add_option("--device", run_device, kDeviceHelp)->check(DeviceValidator());
  run_cmd->add_option("--out", run.out_dir, "Output directory for probes.csv and frames")
      ->capture_default_str();
  run_cmd
      ->add_option("--vtk-every", run.vtk_every,
                   "Write a ParaView frame (OUT/frames/*.vtp, OUT/frames.pvd) every K frames")
      ->check(CLI::Range(1, 1 << 30));
  double vtk_to = 0;
  run_cmd
      ->add_option("--vtk-from", run.vtk_from,
                   "Simulated seconds before which no ParaView frame is written (default 0)")
      ->check(CLI::Range(0.0, 1e6));
  auto* vtk_to_opt =
      run_cmd
          ->add_option("--vtk-to", vtk_to,
                       "Simulated seconds after which no ParaView frame is written (default: the "
                       "end)")
          ->check(CLI::Range(0.0, 1e6));
  run_cmd
      ->add_option("--balance-threshold", run.balance_threshold,
                   "Under mpirun: move the slab cuts when max/mean of the ranks' step times, "
                   "over 10 steps, exceeds this")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 1e6));
  run_cmd
      ->add_option("--rank-timeout", run.rank_timeout,
                   "Under mpirun: seconds a rank waits for the others in one collective before "
                   "it ends the job (one of them hangs)")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 1e6));
  run_cmd->add_flag("--hash", run.print_hash,
                    "Print the final state hash (equal hashes: bit-identical states; the same "
                    "under mpirun at any rank count)");
  run_cmd->footer(ParameterHelp() + kMpiRunHelp);

  dysa::ValidateOptions validate;
  CLI::App* validate_cmd = app.add_subcommand(
      "validate",
      "Run the validation cases (hydrostatic tank, Martin & Moyce dam break, Poiseuille flow, "
      "SPHERIC Test 2) offline and print their errors; exits 1 when a target is missed");
  validate_cmd->add_flag("--quick", validate.quick,
                         "Coarse resolutions with the CI test's bounds (about a minute)");
  validate_cmd->add_option("--solver", validate.solver, "Solver instead of the scenes' (wcsph)");
  validate_cmd->add_option("--case", validate.cases,
                           "Run only this case (repeatable): hydrostatic_tank, dam_break, "
                           "poiseuille_flow, spheric_test2");
  validate_cmd->add_option("--set", validate.sets, "Override a parameter, NAME=VALUE (repeatable)")
      ->check(AssignmentValidator());
  validate_cmd->add_option("--threads", validate.threads, "OpenMP threads (default: all cores)")
      ->check(CLI::Range(1, 1024));
  std::string validate_device = "cpu";
  validate_cmd->add_option("--device", validate_device, kDeviceHelp)->check(DeviceValidator());
  validate_cmd
      ->add_option("--slab-layers", validate.slab_layers,
                   "Particles across each case's 3D slab (default 4; more keeps the side walls "
                   "away from more of the fluid)")
      ->check(CLI::Range(1, 64));

#ifdef DYSA_WITH_REMOTE
  RemoteCommands remote(app);
#endif

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (dynamic_cast<const CLI::RequiredError*>(&e) && app.get_subcommands().empty() &&
        !app.remaining().empty() && !app.remaining().front().starts_with("-")) {
      return UnknownCommand(app);
    }
    // --help exits 0; every usage error exits 2, whatever CLI11's own code for it.
    return app.exit(e) == 0 ? 0 : 2;
  }

#ifdef DYSA_WITH_REMOTE
  if (const std::optional<int> status = remote.Run()) return *status;
#endif

  if (run_cmd->parsed()) {
    if (*end_opt) run.end_time = end_time;
    if (*steps_opt) run.steps = steps;
    if (*vtk_to_opt) run.vtk_to = vtk_to;
    run.progress = isatty(STDERR_FILENO) != 0;
    try {
      run.device = dysa::ParseDevice(run_device);
#ifdef DYSA_WITH_MPI
      if (dysa::distributed::LaunchedByMpirun()) return RunOnRanks(argc, argv, run, run_device);
#endif
      dysa::RunOffline(run, std::cout, std::cerr);
    } catch (const std::exception& e) {
      return ReportError("run", e, run_device, 1);
    }
  }
  if (validate_cmd->parsed()) {
    try {
      validate.device = dysa::ParseDevice(validate_device);
      return dysa::RunValidate(validate, std::cout);
    } catch (const std::exception& e) {
      return ReportError("validate", e, validate_device, 2);
    }
  }
  return 0;
}
