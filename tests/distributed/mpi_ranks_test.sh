#!/bin/bash
# ctest -L mpi: for each scene (tests/distributed/ranks_dam_break.json: wcsph;
# ranks_seed.json: the seed model; ranks_periodic.json: wcsph across the periodic seam of the
# slab axis; ranks_predictor_corrector.json; ranks_half_cells.json: the same with half-support
# cells, the slabs in half-support layers; ranks_dfsph.json: dfsph, its solves refreshing the
# ghosts every iteration), N steps with plain `dysa run` and under mpirun on each rank count must
# end in the same state hash and write the same probes.csv and VTK frames, byte for byte; on more
# than one rank particles must have migrated between ranks and at least two ranks must have held,
# in the mean over the steps, a twentieth of the particles each. (Where the step-time balance moves
# the cuts depends on the machine's timing: mpi_balance_test slows a rank on purpose to check it.
# The count at the end is not asserted: the scenes' fluid moves, the cuts follow it a window
# later, and the seed's block thrown along +x once ended `0 3072` on 2 ranks of a loaded CI
# machine, having held a mean of about a fifth on the first rank.)
# Usage: mpi_ranks_test.sh [--steps N] [--ranks "R..."] DYSA MPIEXEC SCENE... (default: 150
# steps on 1 2 3 4 ranks; ranks_dfsph.json runs 200 steps on 1, 2 and 3). Exits 77 (skipped,
# with the reason printed) when mpirun cannot be found.
set -u
steps=150
rank_counts="1 2 3 4"
while [ $# -gt 0 ]; do
  case $1 in
    --steps) steps=$2 ;;
    --ranks) rank_counts=$2 ;;
    *) break ;;
  esac
  shift 2
done
dysa=$1
mpiexec=$2
shift 2
# shellcheck source=mpi_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/mpi_common.sh"
mpi_require "$mpiexec"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
fail() {
  echo "FAIL: $*"
  exit 1
}

for scene in "$@"; do
  name=$(basename "$scene" .json)
  plain=$("$dysa" run "$scene" --steps $steps --threads 1 --hash --vtk-every 3 \
    --out "$out/$name/plain") ||
    fail "$name: plain dysa run failed: $plain"
  reference=$(field "state hash" "$plain")
  [ -n "$reference" ] || fail "$name: no state hash in: $plain"
  echo "$name, plain dysa run: state hash $reference"
  for ranks in $rank_counts; do
    log=$("$mpiexec" --oversubscribe --allow-run-as-root -np $ranks \
      "$dysa" run "$scene" --steps $steps --threads 1 --hash --vtk-every 3 \
      --out "$out/$name/$ranks" 2>&1) ||
      fail "$name: mpirun -np $ranks failed: $log"
    hash=$(field "state hash" "$log")
    migrated=$(field "migrated" "$log")
    recuts=$(field "re-balanced" "$log")
    counts=$(sed -n 's/^particles per rank: //p' <<< "$log")
    means=$(sed -n 's/^mean particles per rank over the steps: //p' <<< "$log")
    total=$(sed -n "s/^$steps steps of \([0-9]*\) particles.*/\1/p" <<< "$log")
    echo "$name, $ranks ranks: state hash $hash, migrated $migrated, re-balanced $recuts steps," \
      "particles per rank $counts at the end, $means in the mean"
    grep -q "^$steps steps of " <<< "$log" || fail "$name: $ranks ranks ran short: $log"
    [ "$hash" = "$reference" ] || fail "$name: $ranks ranks: hash $hash, not $reference: $log"
    diff -r "$out/$name/plain" "$out/$name/$ranks" > /dev/null ||
      fail "$name: $ranks ranks: probes.csv or frames differ from the plain run's"
    if [ $ranks -gt 1 ]; then
      [ "${migrated:-0}" -gt 0 ] || fail "$name: $ranks ranks: no particle migrated: $log"
      [ "$(wc -w <<< "$means")" -eq "$ranks" ] || fail "$name: no mean per rank in: $log"
      holding=0
      for n in $means; do
        [ $((20 * n)) -ge "$total" ] && holding=$((holding + 1))
      done
      [ $holding -ge 2 ] ||
        fail "$name: $ranks ranks: fewer than two ranks held a twentieth of the $total particles" \
          "in the mean over the steps ($means)"
    fi
  done
done
echo "PASS: the same state hash, probes and frames after $steps steps on ranks" \
  "$(tr ' ' , <<< "$rank_counts") as without mpirun"
