#!/usr/bin/env bash
# How much a client on the same machine slows the server (issue 21, defect 8): the simulated
# frames per second of `dysa-server --threads T --frame-rate 0` on the thesis scene, alone and
# with one `dysa watch` (decoding every frame) beside it. Each measurement resets the
# simulation, lets the client settle for 30 frames, and times the next FRAMES frames from the
# server's frame counter (`dysa status`), so every case covers the same stretch of simulated
# time. The cases alternate for ROUNDS rounds (machine noise hits them alike) and the median is
# reported. Extra cases, 'LABEL=ENV...', run `dysa watch` under `env ENV...`.
#
#   bench/client_interference.sh [BUILD_DIR] [THREADS] [FRAMES] [ROUNDS] [OUT_DIR] [CASE...]
#   bench/client_interference.sh build/release 15 200 3 bench/results 'passive=OMP_WAIT_POLICY=PASSIVE'
#
# Prints every measurement and the medians; writes OUT_DIR/client_interference.csv.
set -euo pipefail

build="${1:-build/release}"
threads="${2:-$(($(nproc) - 1))}"
frames="${3:-200}"
rounds="${4:-3}"
out="${5:-bench/results}"
shift $(($# < 5 ? $# : 5))
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
measure() {
  "$dysa" reset > /dev/null
  wait_for_frame 30
  local t0 t1
  t0=$(now)
  wait_for_frame $((30 + frames))
  t1=$(now)
  awk -v n="$frames" -v t0="$t0" -v t1="$t1" 'BEGIN { printf "%.2f", n / (t1 - t0) }'
}

labels=(alone watch)
envs=("" "")
for spec in "$@"; do
  labels+=("${spec%%=*}")
  envs+=("${spec#*=}")
done

csv="$out/client_interference.csv"
echo "round,case,client_env,frames_per_second" > "$csv"
for round in $(seq "$rounds"); do
  for k in "${!labels[@]}"; do
    label="${labels[$k]}"
    client_pid=""
    if [[ "$label" != "alone" ]]; then
      # shellcheck disable=SC2086
      env ${envs[$k]} "$dysa" watch > "$work/watch.log" 2>&1 &
      client_pid=$!
    fi
    fps=$(measure)
    if [[ -n "$client_pid" ]]; then
      kill "$client_pid" 2> /dev/null || true
      wait "$client_pid" 2> /dev/null || true
    fi
    printf 'round %d  %-16s %8s frames/s  (client env: %s)\n' "$round" "$label" "$fps" \
      "${envs[$k]:-none}"
    echo "$round,$label,${envs[$k]},$fps" >> "$csv"
  done
done
echo "medians over $rounds rounds (dysa-server --threads $threads, $frames frames after a reset):"
for label in "${labels[@]}"; do
  awk -F, -v c="$label" '$2 == c { print $4 }' "$csv" | sort -g |
    awk -v c="$label" '{ v[NR] = $1 } END { m = NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2;
      printf "  %-16s %8.2f frames/s\n", c, m }'
done
echo "wrote $csv"
