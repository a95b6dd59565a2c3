#!/bin/bash
# ctest -L mpi: dysa-server on 3 ranks (mpirun) is the same simulation as dysa-server on one
# process, driven through the `dysa` client: after the same controls (step, a parameter change,
# step back, reset, resume and pause) both report the same frame, step and state hash, and a
# streamed frame (dysa record, npz), of every particle and of a view stream (a camera with a
# budget), is byte-identical; a scene the ranks cannot run (fewer cell
# layers than ranks) is refused naming the field, the old scene running on; wcsph's
# predictor-corrector (time_integration 1) and dfsph run on the ranks to the same hash.
# Usage: mpi_server_test.sh DYSA DYSA_SERVER MPIEXEC SCENE. Exits 77 (skipped, saying why) when
# mpirun cannot be found.
set -u
dysa=$1
server=$2
mpiexec=$3
scene=$4
# shellcheck source=mpi_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/mpi_common.sh"
mpi_require "$mpiexec"
# shellcheck source=mpi_server_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/mpi_server_common.sh"

# same WHAT: both servers are in the same state.
same() {
  local a b
  a=$(state one) || fail "$1: status of the one-process server"
  b=$(state ranks) || fail "$1: status of the ranks' server"
  [ "$a" = "$b" ] || fail "$1: one process '$a', 3 ranks '$b' (frame step hash running)"
  echo "$1: frame step hash running = $a on both"
}
both() {
  on one "$@" > "$out/one.out" 2>&1 || fail "one process: dysa $*: $(cat "$out/one.out")"
  on ranks "$@" > "$out/ranks.out" 2>&1 || fail "3 ranks: dysa $*: $(cat "$out/ranks.out")"
}

start_time=$SECONDS
# A balance threshold out of its range is refused, naming the flag and the range.
if "$server" --scene "$scene" --balance-threshold 0.5 > "$out/threshold" 2>&1; then
  fail "--balance-threshold 0.5 was accepted"
fi
grep -q -- "--balance-threshold" "$out/threshold" && grep -q "1" "$out/threshold" ||
  fail "--balance-threshold 0.5 refused without naming the flag: $(cat "$out/threshold")"
start one
# The ranks re-balance at any imbalance (--balance-threshold 1): the cuts move, the bits do not.
SERVER_ARGS="--balance-threshold 1" start ranks "$mpiexec" --oversubscribe --allow-run-as-root -np 3
on ranks status | grep -q "3 ranks" || fail "the ranks' server does not say it runs on 3 ranks"
same "start"
both step 8
same "step 8"
both set kinematic_viscosity=2e-6
both step 4
same "viscosity changed, step 4"
both back 3
same "back 3"
both step 2
same "step 2 after back"
on one record --frames 1 --fields velocity density --out "$out/one.npz" > /dev/null ||
  fail "record on one process"
on ranks record --frames 1 --fields velocity density --out "$out/ranks.npz" > /dev/null ||
  fail "record on 3 ranks"
cmp "$out/one.npz" "$out/ranks.npz" || fail "the streamed frames differ"
echo "a streamed frame (positions, velocity, density): $(stat -c %s "$out/ranks.npz") bytes, identical"
# A view stream (a camera and a budget): its frame is one process's, byte for byte. (Paused, the
# status's hash has gathered the frame to rank 0 already, so the stream reads rank 0's copy; a
# running server's view streams read each rank's share: mpi_view_reads_test.)
view=(--particle-budget 500 --view "0.6,0.3,0.3,0.2,0.05,0.02" --fields velocity density)
on one record --frames 1 "${view[@]}" --out "$out/one_view.npz" > /dev/null ||
  fail "a view stream's record on one process"
on ranks record --frames 1 "${view[@]}" --out "$out/ranks_view.npz" > /dev/null ||
  fail "a view stream's record on 3 ranks"
cmp "$out/one_view.npz" "$out/ranks_view.npz" || fail "the view streams' frames differ"
echo "a view stream's frame: $(stat -c %s "$out/ranks_view.npz") bytes, identical"
both reset
same "reset"
# Running, then paused: the pause lands on a frame, wherever the ranks' server was.
on ranks resume > /dev/null || fail "resume on 3 ranks"
for _ in $(seq 100); do
  read -r frame _ <<< "$(state ranks)"
  [ "${frame:-0}" -ge 2 ] && break
  sleep 0.2
done
on ranks pause > /dev/null || fail "pause on 3 ranks"
read -r frame _ hash running <<< "$(state ranks)"
[ "$running" = "False" ] || fail "the ranks' server still runs after pause"
[ "$frame" -gt 0 ] || fail "the ranks' server did not run while resumed"
on one step "$frame" > /dev/null || fail "one process: step $frame"
same "resumed, paused at frame $frame"

# Refused, naming the field; the scene runs on: a tank 2 cell layers long cannot give each of 3
# ranks a layer.
cat > "$out/short.json" << 'EOF'
{"name": "short", "domain": {"min": [0, 0, 0], "max": [0.02, 0.02, 0.02]},
 "fluid_blocks": [{"center": [0.01, 0.005, 0.01], "size": [0.02, 0.01, 0.02]}],
 "solver": "wcsph", "params": {"particle_spacing": 0.005}}
EOF
if on ranks load "$out/short.json" > "$out/refused" 2>&1; then
  fail "a scene of 2 cell layers was loaded on 3 ranks"
fi
grep -q "processes" "$out/refused" ||
  fail "2 layers on 3 ranks refused without naming the field: $(cat "$out/refused")"
echo "refused: $(cat "$out/refused")"
on ranks step 1 > /dev/null || fail "step after the refusal"
on one step 1 > /dev/null || fail "one process: step 1"
same "after the refusal, step 1"

# wcsph's predictor-corrector runs on the ranks, to the same bits.
on ranks set time_integration=1 > "$out/set" 2>&1 ||
  fail "the predictor-corrector refused on 3 ranks: $(cat "$out/set")"
on one set time_integration=1 > /dev/null || fail "one process: set time_integration=1"
on ranks step 2 > /dev/null || fail "step with the predictor-corrector"
on one step 2 > /dev/null || fail "one process: step 2 with the predictor-corrector"
same "time_integration=1, step 2"

# dfsph runs on the ranks, to the same bits (its solves refresh the ghosts every iteration).
both load "$scene" --solver dfsph
same "dfsph loaded"
both step 4
same "dfsph, step 4"

# SIGTERM to mpirun ends every rank.
kill -TERM "${pids[1]}"
for _ in $(seq 50); do
  kill -0 "${pids[1]}" 2> /dev/null || break
  sleep 0.2
done
kill -0 "${pids[1]}" 2> /dev/null && fail "mpirun still runs 10 s after SIGTERM"
pgrep -f "$out/ranks.port" > /dev/null && fail "a rank outlived mpirun"
echo "PASS: the server on 3 ranks matches one process ($((SECONDS - start_time)) s)"
