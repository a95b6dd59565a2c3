#!/bin/bash
# ctest -L mpi: a rank that dies, or hangs, under a running dysa-server on 3 ranks ends the
# server. Starts the server running (rank 0 serving, every rank stepping), lets it step a while,
# sends one of the other ranks SIGNAL and asserts that mpirun exits non-zero within 30 s and
# that no rank, rank 0 included, outlives it by more than 10 s: rank 0 must not wait in a
# collective forever.
#   KILL: the rank dies; mpirun sees it and ends the others.
#   STOP: the rank hangs, alive, so mpirun sees nothing: the others' collectives give up after
#         --rank-timeout (2 s here) and end the job, saying so.
# Usage: mpi_server_killed_rank_test.sh DYSA_SERVER MPIEXEC SCENE [KILL|STOP]. Exits 77
# (skipped, saying why) when mpirun cannot be found.
set -u
server=$1
mpiexec=$2
scene=$3
signal=${4:-KILL}
# shellcheck source=mpi_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/mpi_common.sh"
mpi_require "$mpiexec"
out=$(mktemp -d)
fail() {
  echo "FAIL: $*"
  cat "$out/log"
  [ -n "${job:-}" ] && kill -9 "$job" 2> /dev/null
  rm -rf "$out"
  exit 1
}

"$mpiexec" --oversubscribe --allow-run-as-root -np 3 "$server" --scene "$scene" --threads 1 \
  --rank-timeout 2 --listen 127.0.0.1:0 --port-file "$out/port" > "$out/log" 2>&1 &
job=$!
for _ in $(seq 150); do
  [ -f "$out/port" ] && break
  sleep 0.2
done
[ -f "$out/port" ] || fail "the server did not start"
mapfile -t ranks < <(pgrep -P "$job" -x dysa-server)
[ ${#ranks[@]} -eq 3 ] || fail "3 ranks did not start: ${ranks[*]}"
# Let them step a while: the other ranks are then in the step's collectives or waiting for the
# next command.
sleep 2
kill -"$signal" "${ranks[2]}"
echo "sent SIG$signal to rank pid ${ranks[2]} of ${ranks[*]}"
mpi_expect_the_job_ends "$job" "${ranks[@]}"
if [ "$signal" = STOP ]; then
  grep -q "hangs or has died" "$out/log" || fail "no rank said that another one hangs"
  grep "hangs or has died" "$out/log" | head -n 1
fi
rm -rf "$out"
echo "PASS: a rank sent SIG$signal ends the server"
