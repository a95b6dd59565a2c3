#!/usr/bin/env bash
# Why SPHERIC Test 2's impact pressure comes out wrong, one cause at a time (issue "Beat
# DualSPHysics", point 1): the project's Test 2 at one spacing, the base model and one variant
# per suspected cause, each to --end with every step's probes, then the same measures for all
# (bench/spheric2_causes.py: P1/P2 arrival, 1 ms and 5 ms peaks, H errors).
#
#   bench/spheric2_causes.sh [--build build/release] [--device cpu|cuda] [--dp 0.02]
#                            [--end 0.7] [--threads N] [--out bench/results]
#
# Variants (NAME: what it isolates):
#   base       the scene as it is (wcsph, cubic spline, h = d, c0 = 50 m/s, CFL 0.25, delta 0.1)
#   c0_100     the speed of sound doubled: an acoustic spike rho0 c0 dv doubles with it
#   cfl_0.1    a step 2.5 times shorter: what the time integration adds
#   no_diff    no density diffusion (delta = 0): what the diffusion damps
#   cubic_1.73 the cubic spline at h = 1.732 d: the support alone
#   wendland   Wendland C2 at h = 1.732 d (DualSPHysics's kernel and support)
#   dfsph      the incompressible solver: no equation of state, no acoustic waves
#   symplectic DualSPHysics's second-order predictor-corrector (time_integration = 1)
#   dualsph    DualSPHysics's model: Wendland at h = 1.732 d, the predictor-corrector, CFL 0.2
#   shifting   particle shifting at A = 2 (Lind et al. 2012): what a disordered lattice adds
#   contact_0  the wall contact only at the surface (wall_contact_range 0; default 0.4: held at
#              0.2 d): what the inelastic stop of the particles that reach the face adds
#   contact_1  the wall contact at 0.5 d (wall_contact_range 1): a wider inelastic stop
#   rho_min_1  the carried density held at rho0 or above (carried_density_min 1; default 0.7):
#              a tongue whose particles lack neighbours then has pressure once compressed
# Writes spheric2_causes_<device tag>.csv and each variant's step series under --out.
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."

build=build/release
device=cpu
dp=0.02
end=0.7
threads=$(nproc)
out=bench/results
variants="base c0_100 cfl_0.1 no_diff cubic_1.73 wendland dfsph symplectic dualsph shifting contact_0 contact_1 rho_min_1"

usage() {
  sed -n '8,9p' "$0" | sed 's/^# *//' >&2
  exit 2
}
while [[ $# -gt 0 ]]; do
  case "$1" in
    --build) build="$2"; shift 2 ;;
    --device) device="$2"; shift 2 ;;
    --dp) dp="$2"; shift 2 ;;
    --end) end="$2"; shift 2 ;;
    --threads) threads="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --variants) variants="${2//,/ }"; shift 2 ;;
    -h | --help) usage ;;
    *) echo "spheric2_causes.sh: unknown argument '$1'" >&2; usage ;;
  esac
done
case "$device" in
  cpu | cuda | cuda:[0-9]*) ;;
  *) echo "spheric2_causes.sh: --device must be cpu, cuda or cuda:N, not '$device'" >&2; exit 2 ;;
esac
bench="$build/bench/accuracy_bench"
[[ -x "$bench" ]] || { echo "spheric2_causes.sh: no $bench (build it first)" >&2; exit 1; }

tag=cpu
if [[ "$device" != cpu ]]; then
  tag=$(nvidia-smi --query-gpu=name --format=csv,noheader | head -1 | tr ' ' _)
fi
mkdir -p "$out"
runs=()
for v in $variants; do
  args=()
  case "$v" in
    base) ;;
    c0_100) args=(--set speed_of_sound=100) ;;
    cfl_0.1) args=(--set cfl_factor=0.1) ;;
    no_diff) args=(--set density_diffusion=0) ;;
    cubic_1.73) args=(--set smoothing_length_ratio=1.732) ;;
    wendland) args=(--set kernel=1 --set smoothing_length_ratio=1.732) ;;
    dfsph) args=(--solvers dfsph) ;;
    symplectic) args=(--set time_integration=1) ;;
    shifting) args=(--set particle_shifting=2) ;;
    contact_0) args=(--set wall_contact_range=0) ;;
    contact_1) args=(--set wall_contact_range=1) ;;
    rho_min_1) args=(--set carried_density_min=1) ;;
    dualsph)
      args=(--set kernel=1 --set smoothing_length_ratio=1.732 --set time_integration=1
        --set cfl_factor=0.2) ;;
    *) echo "spheric2_causes.sh: unknown variant '$v'" >&2; exit 2 ;;
  esac
  dir="$out/spheric2_causes_${tag}/$v"
  mkdir -p "$dir"
  start=$(date +%s%N)
  "$bench" --case spheric_test2 --device "$device" --threads "$threads" --spacings "$dp" \
    --end "$end" --step-series --out "$dir" "${args[@]}" > "$dir/log.txt" 2>&1
  wall=$((($(date +%s%N) - start) / 1000000))
  echo "$v: $wall ms"
  runs+=(--run "$v" "$wall" "$(ls "$dir"/spheric_test2_steps_*.csv)")
done
compare=(bench/spheric2_causes.py --out "$out/spheric2_causes_${tag}.csv" --dp "$dp" "${runs[@]}")
echo "${compare[*]}" > "$out/spheric2_causes_${tag}/compare_command.txt"
# Debian's numpy (scripts/setup.sh); a GPU box without it keeps the series for a later run.
if /usr/bin/python3 -c 'import numpy' 2> /dev/null; then
  /usr/bin/python3 "${compare[@]}"
else
  echo "no numpy here: run /usr/bin/python3 $(cat "$out/spheric2_causes_${tag}/compare_command.txt")"
fi
