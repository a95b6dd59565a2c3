# Sourced by the tests that drive dysa-server on ranks (mpi_server_test.sh,
# mpi_gpu_server_test.sh), after mpi_common.sh and with $dysa, $server and $scene set: a work
# directory, the servers' cleanup, and how to start a server and ask it.

out=$(mktemp -d)
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill -9 "$pid" 2> /dev/null; done
  rm -rf "$out"
}
trap cleanup EXIT
# fail WHY: prints why and every server's log, and exits 1.
fail() {
  echo "FAIL: $*"
  for log in "$out"/*.log; do
    echo "--- $log"
    cat "$log"
  done
  exit 1
}

# start NAME [mpirun args...]: a paused server on the scene, its address in $out/NAME.addr;
# $SERVER_ARGS, when set, goes to the server's command line.
start() {
  local name=$1
  shift
  # shellcheck disable=SC2086
  "$@" "$server" --scene "$scene" --paused --threads 1 --frame-rate 0 --listen 127.0.0.1:0 \
    --port-file "$out/$name.port" ${SERVER_ARGS:-} > "$out/$name.log" 2>&1 &
  pids+=($!)
  for _ in $(seq 150); do
    [ -f "$out/$name.port" ] && break
    sleep 0.2
  done
  [ -f "$out/$name.port" ] || fail "$name: the server did not start"
  echo "127.0.0.1:$(cat "$out/$name.port")" > "$out/$name.addr"
}
# on NAME ARGS...: the dysa client against server NAME.
on() {
  local name=$1
  shift
  "$dysa" --server "$(cat "$out/$name.addr")" "$@"
}
# state NAME: "frame step hash running" of server NAME (paused: the hash is the frame's).
state() {
  on "$1" --json status | /usr/bin/python3 -c 'import json, sys
s = json.load(sys.stdin)
print(s.get("frame", 0), s.get("step", 0), s.get("state_hash", 0), s.get("running", False))'
}
