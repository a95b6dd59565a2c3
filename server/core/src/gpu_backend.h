// A solver's step on a GPU, behind the narrow interface Simulation uses (step_backend.h): the
// particles live in device memory between steps and cross to the host only when read (frames,
// checkpoints, probes, status) or replaced (reset, restore).
#pragma once

#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "dysa/core/device.h"
#include "dysa/core/model.h"
#include "dysa/core/solver.h"
#include "dysa/core/state.h"
#include "dysa/core/step_backend.h"
#include "dysa/core/view_selection.h"
#include "probe_gather.h"
#include "rank_subset.h"

namespace dysa {

// A backend whose particles live in a CUDA GPU's memory (cuda/cuda_backend.cc).
class GpuBackend : public StepBackend {
 public:
  const DeviceInfo& info() const { return info_; }
  std::string Describe(const Device& device) const override { return info_.Describe(device); }
  // The particles of BelowRank(id, threshold) (threshold > 0; dysa/detail_rank.h) in id order:
  // chosen and packed on the device, so only they cross to the host (cuda/rank_subset.cuh).
  virtual RankSubsetCopy DownloadBelowRank(uint32_t threshold, bool position, bool velocity,
                                           bool density) const = 0;
  // A view stream's subset (dysa/core/view_selection.h): the `budget` smallest keys' particles,
  // ids increasing, chosen and packed on the device (cuda/view_subset.cuh).
  virtual RankSubsetCopy DownloadViewSubset(const ViewSubsetRequest& request, uint64_t budget,
                                            bool position, bool velocity, bool density) const = 0;
  // The particles `ids` (count of them, each below the particle count, in any order): their asked
  // fields packed in the list's order (entry j is ids[j]'s; the copy's ids are `ids`), gathered
  // on the device, so only they cross to the host (cuda/view_reads.cuh).
  virtual RankSubsetCopy DownloadByIds(const uint32_t* ids, size_t count, bool position,
                                       bool velocity, bool density) const = 0;
  // Per axis the smallest (lo[a]) and largest (hi[a]) particle position, reduced on the device:
  // 36 bytes cross (cuda/view_reads.cuh). NaN skipped, a zero extreme signed as the first zero
  // in storage order (Simulation::ReadPositionBounds' bits); lo +inf, hi -inf without particles.
  virtual void DownloadPositionBounds(float* lo, float* hi) const = 0;

 protected:
  DeviceInfo info_;
};

// The GPU backend of `solver` on `device`. Throws ConfigError("device", ...) when the device
// cannot run (naming what is missing) or the solver has no GPU backend.
std::unique_ptr<GpuBackend> CreateGpuBackend(const Device& device, std::string_view solver);

// The solvers with a GPU backend in this build (none without DYSA_CUDA).
std::vector<std::string> GpuSolvers();

}  // namespace dysa
