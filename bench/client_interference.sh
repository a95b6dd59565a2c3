#!/usr/bin/env bash
# How much a client on the same machine slows the server (issue 21, defect 8): the simulated
# frames per second of `dysa-server --threads T --frame-rate 0` on the thesis scene, alone and
# with one `dysa watch` streaming from it, each timed over the same FRAMES frames after a reset
# from the server's frame counter (`dysa status`). Extra cases (the environment a client runs with) come as arguments
# of the form 'LABEL=ENV...' and run `dysa watch` under `env ENV...`.
#
#   bench/client_interference.sh [BUILD_DIR] [THREADS] [FRAMES] [OUT_DIR] [CASE...]
#   bench/client_interference.sh build/release 15 300 bench/results 'passive=OMP_WAIT_POLICY=PASSIVE'
#
# Prints one line per case and writes OUT_DIR/client_interference.csv.
set -euo pipefail

build="${1:-build/release}"
threads="${2:-$(($(nproc) - 1))}"
frames="${3:-300}"
out="${4:-bench/results}"
shift $(($# < 4 ? $# : 4))
server_bin="$build/server/dysa-server"
dysa="$build/clients/cli/dysa"
for bin in "$server_bin" "$dysa"; do
  [[ -x "$bin" ]] || { echo "client_interference.sh: $bin is missing; build first" >&2; exit 1; }
done
mkdir -p "$out"
work=$(mktemp -d)
server_pid=""
cleanup() {
  [[ -n "$server_pid" ]] && kill "$server_pid" 2> /dev/null || true
  jobs -p | xargs -r kill 2> /dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

"$server_bin" --listen 127.0.0.1:0 --port-file "$work/port" --threads "$threads" \
  --frame-rate 0 > "$work/server.log" 2>&1 &
server_pid=$!
for _ in $(seq 100); do [[ -s "$work/port" ]] && break; sleep 0.1; done
export DYSA_SERVER="127.0.0.1:$(cat "$work/port")"

frame() { "$dysa" status | awk '$1 == "frame" { print $2 }'; }
now() { date +%s.%N; }
wait_for_frame() { while (($(frame) < $1)); do sleep 0.05; done; }
# Frames per wall second over the same stretch of simulated time in every case (the cost of a
# frame changes as the fluid moves): reset, let the client connect and settle for 30 frames,
# then time the next $frames.
measure() {
  "$dysa" reset > /dev/null
  wait_for_frame 30
  local t0 t1
  t0=$(now)
  wait_for_frame $((30 + frames))
  t1=$(now)
  awk -v n="$frames" -v t0="$t0" -v t1="$t1" 'BEGIN { print n / (t1 - t0) }'
}

echo "case,client_env,frames_per_second" > "$out/client_interference.csv"
run_case() {
  local label="$1"
  shift
  local client_pid=""
  if [[ "$label" != "alone" ]]; then
    env "$@" "$dysa" watch > "$work/watch_$label.log" 2>&1 &
    client_pid=$!
  fi
  local fps
  fps=$(measure)
  [[ -n "$client_pid" ]] && { kill "$client_pid" 2> /dev/null || true; wait "$client_pid" 2> /dev/null || true; }
  printf '%-24s %8.1f frames/s  (server --threads %s, client env: %s)\n' "$label" "$fps" "$threads" "${*:-none}"
  echo "$label,${*:-},$fps" >> "$out/client_interference.csv"
}

run_case alone
run_case watch
for spec in "$@"; do
  label="${spec%%=*}"
  env_text="${spec#*=}"
  # shellcheck disable=SC2086
  run_case "$label" $env_text
done
run_case alone_again
echo "wrote $out/client_interference.csv"
