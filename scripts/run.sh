#!/usr/bin/env bash
# The main job: starts dysa-server with the thesis's test scene (91,125 particles) and watches it.
# With a display and a built viewer, the viewer opens on it; otherwise `dysa watch` shows a live
# status line (frame, simulated time, frames/s, bytes per frame) for DYSA_WATCH_SECONDS (default
# 20) seconds. Then the server is stopped (SIGTERM) and its log tail shown.
#
#   scripts/run.sh                          # as above, on 127.0.0.1:50051
#   DYSA_PORT=50052 scripts/run.sh          # another port
#   scripts/run.sh --scene seed_basic       # extra arguments go to dysa-server (dysa-server --help)
#   DYSA_KEEP_RUNNING=1 scripts/run.sh      # leave the server running after the watch, for scripts
#
# The offline run of the first version stays available: build/release/clients/cli/dysa run SCENE.
# Installs missing packages and builds the release preset first.
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."

scripts/build.sh release

port="${DYSA_PORT:-50051}"
address="127.0.0.1:${port}"
bin=build/release
log="out/dysa-server.log"
mkdir -p out

# The scene default is left out when the caller gives --scene (dysa-server rejects an option
# given twice).
scene=(--scene seed_test_scene)
for arg in "$@"; do
  case "$arg" in
    --scene | --scene=*) scene=() ;;
  esac
done

"$bin/server/dysa-server" "${scene[@]}" --listen "$address" "$@" 2> "$log" &
server_pid=$!
stop_server() {
  if kill -0 "$server_pid" 2> /dev/null; then
    kill -TERM "$server_pid"
    wait "$server_pid" || true
  fi
}
if [[ -z "${DYSA_KEEP_RUNNING:-}" ]]; then
  trap stop_server EXIT
fi

# Wait until it answers (it fails fast on a bad flag or a port in use: show why).
for _ in $(seq 1 100); do
  if "$bin/clients/cli/dysa" --server "$address" status > /dev/null 2>&1; then
    break
  fi
  if ! kill -0 "$server_pid" 2> /dev/null; then
    cat "$log" >&2
    echo "run.sh: dysa-server did not start (log above)" >&2
    exit 1
  fi
  sleep 0.1
done
echo "run.sh: dysa-server is listening on $address (log: $log)"

if [[ -n "${DISPLAY:-}" && -x "$bin/viewer/dysa-viewer" ]]; then
  "$bin/viewer/dysa-viewer" --server "$address"
else
  "$bin/clients/cli/dysa" --server "$address" watch --seconds "${DYSA_WATCH_SECONDS:-20}"
fi
"$bin/clients/cli/dysa" --server "$address" status

if [[ -n "${DYSA_KEEP_RUNNING:-}" ]]; then
  echo "run.sh: dysa-server keeps running (pid $server_pid); stop it with: kill $server_pid"
else
  stop_server
  echo "run.sh: server log (last lines):"
  tail -n 5 "$log"
fi
