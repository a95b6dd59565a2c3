#!/usr/bin/env bash
# The slabs' balance over a long run (issue "Past one process": max/mean of the ranks' step times
# <= 1.10 on the dam break over 10^4 steps): `mpirun -np N dysa run SCENE --steps S` prints the
# ranks' step time max/mean over the first 10-step window, the last, and the mean of every
# window (docs/distributed.md, "Re-balancing by step time"), the cuts it moved and the particles
# per rank. One row per run is appended to OUT/balance_cpu.csv.
#
#   bench/balance_bench.sh [--ranks N] [--steps S] [--threads T] [--scene S] [--set NAME=VALUE]...
#                          [--out bench/results]
#
# Defaults: 2 ranks, 10,000 steps, 1 thread per rank, dam_break_martin_moyce. Needs a release
# build of dysa with MPI (build/release, or DYSA=path).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

usage="usage: bench/balance_bench.sh [--ranks N] [--steps S] [--threads T] [--scene S] [--set NAME=VALUE]... [--out DIR]"
ranks=2 steps=10000 threads=1 scene=dam_break_martin_moyce out=bench/results
sets=() assignments=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    --ranks) ranks="$2"; shift 2 ;;
    --steps) steps="$2"; shift 2 ;;
    --threads) threads="$2"; shift 2 ;;
    --scene) scene="$2"; shift 2 ;;
    --set) sets+=(--set "$2"); assignments+=("$2"); shift 2 ;;
    --out) out="$2"; shift 2 ;;
    *) echo "$usage" >&2; exit 2 ;;
  esac
done
dysa="${DYSA:-build/release/clients/cli/dysa}"
[[ -x "$dysa" ]] || { echo "balance_bench.sh: no $dysa (build it: cmake --build build/release --target dysa)" >&2; exit 1; }
command -v mpirun > /dev/null || { echo "balance_bench.sh: mpirun is missing (scripts/setup.sh installs Open MPI)" >&2; exit 1; }

log=$(mktemp)
run_out=$(mktemp -d)
trap 'rm -rf "$log" "$run_out"' EXIT
mpirun --oversubscribe --allow-run-as-root -np "$ranks" "$dysa" run "$scene" --steps "$steps" \
  --threads "$threads" "${sets[@]}" --out "$run_out" | tee "$log"

# "step time max/mean: 1.03 over the first 10 steps, 1.01 over the last 10, 1.05 in the mean of
# the 999 windows (threshold 1.10)"
balance=$(grep "step time max/mean:" "$log")
first=$(sed -E 's/.*max\/mean: ([0-9.]+) over the first.*/\1/' <<< "$balance")
last=$(sed -E 's/.*, ([0-9.]+) over the last.*/\1/' <<< "$balance")
mean=$(sed -E 's/.*, ([0-9.]+) in the mean of the ([0-9]+) windows.*/\1/' <<< "$balance")
windows=$(sed -E 's/.*in the mean of the ([0-9]+) windows.*/\1/' <<< "$balance")
particles=$(sed -nE 's/^[0-9]+ steps of ([0-9]+) particles in ([0-9.]+) s.*/\1/p' "$log")
wall=$(sed -nE 's/^[0-9]+ steps of ([0-9]+) particles in ([0-9.]+) s.*/\2/p' "$log")
moved=$(sed -nE 's/^re-balanced: ([0-9]+) of.*/\1/p' "$log")
mean_counts=$(sed -nE 's/^mean particles per rank over the steps: (.*)/\1/p' "$log")

mkdir -p "$out"
csv="$out/balance_cpu.csv"
[[ -f "$csv" ]] || echo "scene,settings,ranks,threads,steps,particles,wall_s,max_mean_first,max_mean_last,max_mean_of_windows,windows,cuts_moved,mean_particles_per_rank" > "$csv"
settings=$(IFS=';'; echo "${assignments[*]:-}")
echo "$scene,$settings,$ranks,$threads,$steps,$particles,$wall,$first,$last,$mean,$windows,$moved,$mean_counts" >> "$csv"
echo "balance: max/mean $mean in the mean of $windows windows (target <= 1.10); appended to $csv"
