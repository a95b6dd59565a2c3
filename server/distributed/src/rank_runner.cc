// The commands process 0 broadcasts to the server's ranks, and what each process does with one.
// A command is a kind byte and its fields in this process's native layout (every rank runs the
// same build on the same kind of host).
#include "dysa/distributed/rank_runner.h"

#include <array>
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace dysa::distributed {
namespace {

enum class Kind : uint8_t {
  kScene = 1,
  kConfigure,
  kUpload,
  kStep,
  kGather,
  kCheckpoint,
  kStop,
  kReadIds,
  kPositionBounds,
  kViewSubset
};

class Writer {
 public:
  explicit Writer(Kind kind) { bytes_.push_back(std::byte(kind)); }
  void Raw(const void* data, size_t size) {
    const auto* at = static_cast<const std::byte*>(data);
    bytes_.insert(bytes_.end(), at, at + size);
  }
  template <class T>
  void Put(const T& value) {
    Raw(&value, sizeof(T));
  }
  void Text(const std::string& text) {
    Put(uint64_t(text.size()));
    Raw(text.data(), text.size());
  }
  void Values(const Params& params) {
    Put(uint64_t(ParamTable().size()));
    for (const ParamDecl& decl : ParamTable()) Put(decl.get(params));
  }
  Bytes Take() { return std::move(bytes_); }

 private:
  Bytes bytes_;
};

class Reader {
 public:
  explicit Reader(const Bytes& bytes) : bytes_(bytes) {}
  void Raw(void* data, size_t size) {
    if (size > bytes_.size() - at_) throw std::logic_error("a rank command ended early");
    std::memcpy(data, bytes_.data() + at_, size);
    at_ += size;
  }
  template <class T>
  T Get() {
    T value;
    Raw(&value, sizeof(T));
    return value;
  }
  std::string Text() {
    std::string text(Get<uint64_t>(), '\0');
    Raw(text.data(), text.size());
    return text;
  }
  // Applies the values in ParamTable order to `params` (each validated again).
  void Values(Params& params) {
    const uint64_t n = Get<uint64_t>();
    if (n != ParamTable().size()) throw std::logic_error("a rank command's parameters differ");
    for (const ParamDecl& decl : ParamTable()) SetParam(params, decl.name, Get<double>());
  }

 private:
  const Bytes& bytes_;
  size_t at_ = 1;  // past the kind
};

}  // namespace

Bytes SceneCommand(const Scene& scene) {
  Writer w(Kind::kScene);
  w.Text(scene.source_json);
  w.Text(scene.name);
  w.Text(scene.solver);
  w.Values(scene.params);
  return w.Take();
}

Bytes ConfigureCommand(const Params& params) {
  Writer w(Kind::kConfigure);
  w.Values(params);
  return w.Take();
}

Bytes UploadCommand(const ParticleArrays& p, std::span<const SolverArray> arrays) {
  Writer w(Kind::kUpload);
  const size_t n = p.size();
  w.Put(uint64_t(n));
  w.Raw(p.id.data(), n * sizeof(uint32_t));
  for (size_t i = 0; i < n; ++i) w.Raw(p.position[i].data(), 3 * sizeof(Real));
  for (size_t i = 0; i < n; ++i) w.Raw(p.velocity[i].data(), 3 * sizeof(Real));
  w.Put(uint64_t(arrays.size()));
  for (const SolverArray& a : arrays) {
    w.Text(a.name);
    w.Put(uint64_t(a.values.size()));
    w.Raw(a.values.data(), a.values.size() * sizeof(Real));
  }
  return w.Take();
}

Bytes StepCommand(double time, uint64_t step, double max_dt) {
  Writer w(Kind::kStep);
  w.Put(time);
  w.Put(step);
  w.Put(max_dt);
  return w.Take();
}

Bytes GatherCommand(uint32_t threshold) {
  Writer w(Kind::kGather);
  w.Put(threshold);
  return w.Take();
}
Bytes CheckpointCommand() { return Writer(Kind::kCheckpoint).Take(); }

Bytes ReadIdsCommand(std::span<const uint32_t> ids, uint32_t fields) {
  Writer w(Kind::kReadIds);
  w.Put(fields);
  w.Put(uint64_t(ids.size()));
  w.Raw(ids.data(), ids.size() * sizeof(uint32_t));
  return w.Take();
}

Bytes PositionBoundsCommand() { return Writer(Kind::kPositionBounds).Take(); }

Bytes ViewSubsetCommand(const ViewSubsetRequest& request, uint64_t budget, uint32_t fields) {
  Writer w(Kind::kViewSubset);
  w.Put(request.box_min);
  w.Put(request.box_max);
  w.Put(request.stride);
  w.Put(budget);
  w.Put(fields);
  return w.Take();
}

Bytes StopCommand() { return Writer(Kind::kStop).Take(); }

RankResult RankRunner::Send(Bytes command, const ViewWeigher* weigh) {
  comm_.Broadcast(command);
  return Run(command, weigh);
}

bool RankRunner::ServeOne() {
  Bytes command;
  comm_.Broadcast(command);
  try {
    return !Run(command).stop;
  } catch (const ConfigError& e) {
    // A GPU that failed here (its memory, its driver) may have failed on this process alone,
    // while the others wait for it in the scene's collectives: not for process 0 to report.
    if (e.field() == "device") throw std::runtime_error(std::string("--device: ") + e.what());
    return true;  // process 0 throws the same and reports it
  }
}

RankResult RankRunner::Run(const Bytes& command, const ViewWeigher* weigh) {
  if (command.empty()) throw std::logic_error("an empty rank command");
  const Kind kind = Kind(command[0]);
  Reader r(command);
  RankResult result;
  if (kind == Kind::kStop) {
    result.stop = true;
    return result;
  }
  if (kind == Kind::kScene) {
    Scene scene = ParseScene(r.Text());
    scene.name = r.Text();
    scene.solver = r.Text();
    r.Values(scene.params);
    try {
      // GPU ranks (on a stand-in in tests). Process 0 refused what they cannot run before it
      // sent the scene (CheckRunsOnRanks with device()); the old simulation stays until the new
      // one is built.
      const Device device = this->device();
      if (device.is_cuda() && stand_in_) {
        std::unique_ptr<StepBackend> stand_in = stand_in_(scene.solver);
        sim_ =
            std::make_unique<DistributedSimulation>(std::move(scene), comm_, std::move(stand_in));
      } else {
        sim_ = std::make_unique<DistributedSimulation>(std::move(scene), comm_, device);
      }
      sim_->set_balance(balance_);
    } catch (const std::invalid_argument& e) {
      throw ConfigError("processes", e.what());  // more ranks than the grid has layers
    }
    return result;
  }
  if (!sim_) throw std::logic_error("a rank command before the first scene");
  switch (kind) {
    case Kind::kConfigure: {
      Params params = sim_->model().params;
      r.Values(params);
      sim_->SetParams(params);
      break;
    }
    case Kind::kUpload: {
      Checkpoint c;
      c.params = sim_->model().params;
      const size_t n = r.Get<uint64_t>();
      c.id.resize(n);
      c.position.resize(n);
      c.velocity.resize(n);
      r.Raw(c.id.data(), n * sizeof(uint32_t));
      for (size_t i = 0; i < n; ++i) r.Raw(c.position[i].data(), 3 * sizeof(Real));
      for (size_t i = 0; i < n; ++i) r.Raw(c.velocity[i].data(), 3 * sizeof(Real));
      c.solver_arrays.resize(r.Get<uint64_t>());
      for (SolverArray& a : c.solver_arrays) {
        a.name = r.Text();
        a.values.resize(r.Get<uint64_t>());
        r.Raw(a.values.data(), a.values.size() * sizeof(Real));
      }
      sim_->RestoreCheckpoint(c);
      break;
    }
    case Kind::kStep: {
      const double time = r.Get<double>();
      const uint64_t step = r.Get<uint64_t>();
      const double max_dt = r.Get<double>();
      result.outcome = sim_->StepAt(time, step, max_dt);
      break;
    }
    case Kind::kGather: {
      const uint32_t threshold = r.Get<uint32_t>();
      result.particles =
          threshold ? sim_->GatherParticlesBelowRank(threshold) : sim_->GatherParticles();
      break;
    }
    case Kind::kCheckpoint:
      result.checkpoint = sim_->SaveCheckpoint();
      break;
    case Kind::kReadIds: {
      const uint32_t fields = r.Get<uint32_t>();
      std::vector<uint32_t> ids(r.Get<uint64_t>());
      r.Raw(ids.data(), ids.size() * sizeof(uint32_t));
      result.particles = sim_->GatherParticlesByIds(ids, fields);
      break;
    }
    case Kind::kPositionBounds:
      result.bounds = sim_->PositionBounds();
      break;
    case Kind::kViewSubset: {
      ViewSubsetRequest request;
      request.box_min = r.Get<std::array<double, 3>>();
      request.box_max = r.Get<std::array<double, 3>>();
      request.stride = r.Get<uint32_t>();
      const uint64_t budget = r.Get<uint64_t>();
      const uint32_t fields = r.Get<uint32_t>();
      if (weigh) request.weigh = *weigh;
      GatheredViewSubset subset = sim_->SelectViewSubset(request, budget, fields);
      result.ids = std::move(subset.ids);
      result.particles = std::move(subset.particles);
      break;
    }
    default:
      throw std::logic_error("an unknown rank command " + std::to_string(int(kind)));
  }
  return result;
}

void ServeRanks(RankRunner& runner) {
  while (runner.ServeOne()) {
  }
}

}  // namespace dysa::distributed
