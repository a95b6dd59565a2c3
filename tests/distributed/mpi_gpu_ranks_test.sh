#!/bin/bash
# ctest -L gpu (and -L mpi): GPU ranks. For each scene (wcsph: ranks_dam_break.json,
# ranks_periodic.json; ranks_predictor_corrector.json, ranks_seed.json and ranks_dfsph.json, 200
# steps, each in its own test), N steps of plain `dysa run` on the CPU give the
# reference state hash; `mpirun -np R dysa run SCENE --device cuda` on R = 1, 2, 3 ranks sharing
# cuda:0 (each rank maps to GPU local_rank % GPUs) must end in that same hash, and write the
# same probes.csv and VTK frames on every rank count (the GPU's, byte for byte); plain
# `dysa run --device cuda` is run too, to tell a rank bug (ranks differ from the one-GPU run)
# from a CPU/GPU difference (the one-GPU run itself differs from the CPU, docs/gpu.md). On more
# than one rank particles must have migrated and at least two ranks hold some.
# Usage: mpi_gpu_ranks_test.sh [--steps N] [--ranks "R..."] DYSA MPIEXEC SCENE... (default: 150
# steps on 1 2 3 ranks). Exits 77 (skipped, with the reason printed) when mpirun cannot be
# found or no CUDA GPU can run.
set -u
steps=150
rank_counts="1 2 3"
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

# The GPU: `dysa run --device cuda` refuses a device that cannot run with status 2, saying why.
probe=$("$dysa" run "$1" --steps 1 --threads 1 --device cuda --out "$out/probe" 2>&1)
status=$?
if [ $status -eq 2 ] && grep -q -- "--device" <<< "$probe"; then
  echo "SKIP: no CUDA GPU to run GPU ranks on: $probe"
  exit 77
fi
[ $status -eq 0 ] || fail "dysa run --device cuda failed: $probe"

for scene in "$@"; do
  name=$(basename "$scene" .json)
  args=(run "$scene" --steps "$steps" --threads 1 --hash --vtk-every 3)
  cpu=$("$dysa" "${args[@]}" --out "$out/$name/cpu") || fail "$name: plain dysa run failed: $cpu"
  reference=$(field "state hash" "$cpu")
  [ -n "$reference" ] || fail "$name: no state hash in: $cpu"
  gpu=$("$dysa" "${args[@]}" --device cuda --out "$out/$name/gpu") ||
    fail "$name: dysa run --device cuda failed: $gpu"
  gpu_hash=$(field "state hash" "$gpu")
  echo "$name: plain dysa run: state hash $reference; --device cuda: $gpu_hash"
  for ranks in $rank_counts; do
    log=$("$mpiexec" --oversubscribe --allow-run-as-root -np "$ranks" \
      "$dysa" "${args[@]}" --device cuda --out "$out/$name/$ranks" 2>&1) ||
      fail "$name: mpirun -np $ranks --device cuda failed: $log"
    hash=$(field "state hash" "$log")
    migrated=$(field "migrated" "$log")
    counts=$(sed -n 's/^particles per rank: //p' <<< "$log")
    devices=$(sed -n 's/^devices per rank: //p' <<< "$log")
    echo "$name, $ranks GPU ranks ($devices): state hash $hash, migrated $migrated," \
      "particles per rank $counts"
    grep -q "^$steps steps of " <<< "$log" || fail "$name: $ranks GPU ranks ran short: $log"
    [ "$(wc -w <<< "$devices")" -eq "$ranks" ] || fail "$name: no device per rank in: $log"
    if [ "$hash" != "$gpu_hash" ]; then
      fail "$name: $ranks GPU ranks: hash $hash, not the one GPU's $gpu_hash (CPU: $reference)"
    fi
    [ "$hash" = "$reference" ] ||
      fail "$name: $ranks GPU ranks: hash $hash equals the one GPU's but not the CPU's" \
        "$reference: the GPU's solver differs from the CPU's on this scene (docs/gpu.md)"
    if [ "$ranks" != "${rank_counts%% *}" ]; then
      diff -r "$out/$name/${rank_counts%% *}" "$out/$name/$ranks" > /dev/null ||
        fail "$name: $ranks GPU ranks: probes.csv or frames differ from ${rank_counts%% *} rank's"
    fi
    if [ "$ranks" -gt 1 ]; then
      [ "${migrated:-0}" -gt 0 ] || fail "$name: $ranks GPU ranks: no particle migrated: $log"
      holding=0
      for n in $counts; do
        [ "$n" -gt 0 ] && holding=$((holding + 1))
      done
      [ $holding -ge 2 ] ||
        fail "$name: $ranks GPU ranks: fewer than two ranks hold particles ($counts)"
    fi
  done
done
echo "PASS: GPU ranks $(tr ' ' , <<< "$rank_counts") end in the CPU's state hash after" \
  "$steps steps, with the same probes and frames on every rank count"
