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
# shellcheck source=mpi_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/mpi_common.sh"
mpi_require "$mpiexec"
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
mpi_expect_the_job_ends "$job" "${ranks[@]}"
rm -rf "$out"
echo "PASS: a killed rank ends the job"
