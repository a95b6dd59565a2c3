#!/bin/bash
# ctest -L gpu (and -L mpi): dysa-server on 3 GPU ranks (`mpirun -np 3 dysa-server --device
# cuda`: each rank steps its slab on GPU local_rank % GPUs) is the same simulation as dysa-server
# on one process, on the GPU and on the CPU, driven through the `dysa` client: after the same
# controls (step, a parameter change, step back, reset, the predictor-corrector, the seed's scene,
# dfsph's scene and the first scene loaded with --solver dfsph) all report the same frame, step
# and state hash, and a streamed frame (dysa record, npz) is byte-identical to the one GPU's. The
# one-GPU server tells a rank bug (the ranks differ from it) from a CPU/GPU difference (it
# differs from the CPU, docs/gpu.md).
# Usage: mpi_gpu_server_test.sh DYSA DYSA_SERVER MPIEXEC SCENE SEED_SCENE DFSPH_SCENE. Exits 77
# (skipped, printing why) when mpirun cannot be found or no CUDA GPU can run.
set -u
dysa=$1
server=$2
mpiexec=$3
scene=$4
seed_scene=$5
dfsph_scene=$6
# shellcheck source=mpi_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/mpi_common.sh"
mpi_require "$mpiexec"
# shellcheck source=mpi_server_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/mpi_server_common.sh"

# The GPU: `dysa run --device cuda` refuses a device that cannot run with status 2, saying why.
probe=$("$dysa" run "$scene" --steps 1 --threads 1 --device cuda --out "$out/probe" 2>&1)
status=$?
if [ $status -eq 2 ] && grep -q -- "--device" <<< "$probe"; then
  echo "SKIP: no CUDA GPU to run the server's GPU ranks on: $probe"
  exit 77
fi
[ $status -eq 0 ] || fail "dysa run --device cuda failed: $probe"

# same WHAT: the GPU ranks are in the one GPU's state, and that is the CPU's.
same() {
  local cpu gpu ranks
  cpu=$(state cpu) || fail "$1: status of the CPU server"
  gpu=$(state gpu) || fail "$1: status of the one-GPU server"
  ranks=$(state ranks) || fail "$1: status of the GPU ranks' server"
  [ "$ranks" = "$gpu" ] || fail "$1: 3 GPU ranks '$ranks', one GPU '$gpu' (CPU '$cpu')"
  [ "$ranks" = "$cpu" ] || fail "$1: 3 GPU ranks '$ranks' equal the one GPU's but not the" \
    "CPU's '$cpu': the GPU's solver differs from the CPU's on this scene (docs/gpu.md)"
  echo "$1: frame step hash running = $ranks on all three"
}
all() {
  local name
  for name in cpu gpu ranks; do
    on "$name" "$@" > "$out/$name.out" 2>&1 || fail "$name: dysa $*: $(cat "$out/$name.out")"
  done
}

start_time=$SECONDS
SERVER_ARGS="--device cpu" start cpu
SERVER_ARGS="--device cuda" start gpu
SERVER_ARGS="--device cuda" start ranks "$mpiexec" --oversubscribe --allow-run-as-root -np 3
device=$(on ranks --json status | /usr/bin/python3 -c 'import json, sys
print(json.load(sys.stdin).get("device", ""))')
echo "the GPU ranks' server runs on: $device"
grep -q "^cuda:.*, 3 ranks$" <<< "$device" || fail "the status does not say 3 GPU ranks: $device"
same "start"
all step 8
same "step 8"
all set kinematic_viscosity=2e-6
all step 4
same "viscosity changed, step 4"
all back 3
same "back 3"
all step 2
same "step 2 after back"
on gpu record --frames 1 --fields velocity density --out "$out/gpu.npz" > /dev/null ||
  fail "record on one GPU"
on ranks record --frames 1 --fields velocity density --out "$out/ranks.npz" > /dev/null ||
  fail "record on 3 GPU ranks"
cmp "$out/gpu.npz" "$out/ranks.npz" || fail "the streamed frames differ"
echo "a streamed frame: $(stat -c %s "$out/ranks.npz") bytes, identical"
all reset
same "reset"

all step 1
same "after the reset, step 1"

# wcsph's predictor-corrector and the seed on the GPU ranks, to the same bits.
all set time_integration=1
all step 2
same "time_integration=1, step 2"
all load "$seed_scene"
all step 4
same "the seed, step 4"

# dfsph on the GPU ranks: its ghosts refreshed through the device after every velocity update
# inside the solves, its mean errors combined over the ranks.
all load "$dfsph_scene"
all step 6
same "dfsph's scene, step 6"
all back 2
same "dfsph's scene, back 2"
all load "$scene" --solver dfsph
all step 4
same "the first scene with --solver dfsph, step 4"

# SIGTERM to mpirun ends every rank.
kill -TERM "${pids[2]}"
for _ in $(seq 50); do
  kill -0 "${pids[2]}" 2> /dev/null || break
  sleep 0.2
done
kill -0 "${pids[2]}" 2> /dev/null && fail "mpirun still runs 10 s after SIGTERM"
pgrep -f "$out/ranks.port" > /dev/null && fail "a rank outlived mpirun"
echo "PASS: the server on 3 GPU ranks matches one GPU and the CPU ($((SECONDS - start_time)) s)"
