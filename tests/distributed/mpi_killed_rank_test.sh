#!/bin/bash
# ctest -L mpi: a rank that dies mid-run ends the whole job. Starts a long `mpirun -np 3 dysa
# run`, kills one of its ranks (SIGKILL, by the pid mpirun started) once the ranks are stepping,
# and asserts that mpirun exits non-zero within 30 s and no rank outlives it by more than 10 s,
# rather than the other ranks waiting forever in a collective.
# Usage: mpi_killed_rank_test.sh DYSA MPIEXEC SCENE. Exits 77 (skipped, saying why) when mpirun
# cannot be found.
set -u
dysa=$1
mpiexec=$2
scene=$3
if ! command -v "$mpiexec" > /dev/null 2>&1; then
  echo "SKIP: no mpirun ('$mpiexec' not found): install openmpi-bin (scripts/setup.sh)"
  exit 77
fi
export OMP_WAIT_POLICY=PASSIVE
export ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0"
out=$(mktemp -d)
fail() {
  echo "FAIL: $*"
  [ -n "${job:-}" ] && kill -9 "$job" 2> /dev/null
  rm -rf "$out"
  exit 1
}

"$mpiexec" --oversubscribe --allow-run-as-root -np 3 "$dysa" run "$scene" --steps 1000000 \
  --threads 1 --out "$out/run" > "$out/log" 2>&1 &
job=$!
# The ranks are mpirun's children: wait until all three run, then give them time to start
# stepping.
ranks=()
for _ in $(seq 100); do
  mapfile -t ranks < <(pgrep -P "$job" -x dysa)
  [ ${#ranks[@]} -eq 3 ] && break
  sleep 0.2
done
[ ${#ranks[@]} -eq 3 ] || fail "3 ranks did not start: $(cat "$out/log")"
sleep 3
kill -9 "${ranks[1]}"
echo "killed rank pid ${ranks[1]} of ${ranks[*]}"
start=$SECONDS
for _ in $(seq 150); do
  kill -0 "$job" 2> /dev/null || break
  sleep 0.2
done
kill -0 "$job" 2> /dev/null && fail "mpirun still runs 30 s after a rank was killed"
wait "$job"
status=$?
echo "mpirun exited with status $status after $((SECONDS - start)) s"
[ $status -ne 0 ] || fail "mpirun exited 0 after a rank was killed"
# mpirun's teardown of the other ranks may finish just after it exits.
for pid in "${ranks[@]}"; do
  for _ in $(seq 50); do
    kill -0 "$pid" 2> /dev/null || break
    sleep 0.2
  done
  kill -0 "$pid" 2> /dev/null && fail "rank pid $pid still runs 10 s after mpirun exited"
done
rm -rf "$out"
echo "PASS: a killed rank ends the job"
