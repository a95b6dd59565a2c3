// `dysa validate`: the validation cases of dysa/validation/validation.h with their errors and
// targets.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

#include "dysa/core/device.h"

namespace dysa {

struct ValidateOptions {
  bool quick = false;             // the coarse resolutions of the CI test (tests/validation)
  std::string solver;             // "": the scenes' (wcsph)
  int threads = 0;                // 0: OpenMP's default
  int slab_layers = 4;            // particles across each case's slab (kSlabLayers)
  std::vector<std::string> sets;  // NAME=VALUE overrides for every case
  Device device;                  // where the cases step (--device)
  // The cases to run, by ValidationCaseNames(); empty: every case.
  std::vector<std::string> cases;
};

// "hydrostatic_tank" (wcsph, and dfsph unless --solver), "dam_break" (the instant release, the
// gate, the residual height), "poiseuille_flow", "spheric_test2".
const std::vector<std::string>& ValidationCaseNames();

// Runs the cases (every one by default), prints one table row per measure (value, target,
// ok/MISSED) to `out`, and returns 0 when every target is met, 1 otherwise. Throws ConfigError for
// bad options (an unknown case: field "--case"), and ConfigError("device", ...) before any case
// runs when options.device cannot run.
int RunValidate(const ValidateOptions& options, std::ostream& out);

}  // namespace dysa
