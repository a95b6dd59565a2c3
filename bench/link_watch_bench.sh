#!/usr/bin/env bash
# Watching a large run over a shaped link (issue 32's link targets), without tc: dysa-server
# steps a wcsph dam break of --particles particles (on --device, e.g. cuda on the GPU box);
# dysa-delay-relay stands for the link (--rate-mbit each way, --delay-ms each way: a user-space
# link, where iproute2 is missing); `dysa watch --fps-target F` subscribes through it for
# --seconds. Measured: the simulated frame rate before anyone watches and while the stream runs
# (the watch's cost), the frames the client received per second against the frames simulated
# in the same time (the target: every simulated frame), the particles and bytes per frame, and
# the server's own view of the stream once a second (detail, delivered bytes/s, age of the shown
# data).
#
#   bench/link_watch_bench.sh [--particles N] [--device cuda] [--rate-mbit R] [--delay-ms D]
#                             [--fps-target F] [--seconds S] [--view EX,EY,EZ,TX,TY,TZ]
#                             [--view-jumps J] [--dwell S] [--pause-wait S] [--out bench/results]
#
# With --view-jumps J > 0, view_link_bench then watches through the same link with a camera
# that jumps J times (--dwell seconds on each) and pauses the server at the end: how soon the
# new view and the complete frame (waited for --pause-wait seconds at most) arrive
# (bench/view_link_bench.cc). Appends to OUT/view_link_<device name>.csv.
#
# Appends a row to OUT/link_watch_<device name>.csv and writes the status samples to
# OUT/link_watch_<particles>_<rate>mbit_<device name>.txt. Needs a release build of
# dysa-server, dysa and dysa-delay-relay (tests/link), in build/release or $LINK_BENCH_BUILD.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

particles=10000000
device=cuda
rate_mbit=1000
delay_ms=0
fps_target=15
seconds=20
view=""
view_jumps=0
dwell=4
pause_wait=60
out=bench/results
usage="usage: bench/link_watch_bench.sh [--particles N] [--device D] [--rate-mbit R] [--delay-ms D] [--fps-target F] [--seconds S] [--view EX,EY,EZ,TX,TY,TZ] [--view-jumps J] [--dwell S] [--pause-wait S] [--out DIR]"
while [[ $# -gt 0 ]]; do
  case "$1" in
    --particles) particles="$2"; shift 2 ;;
    --device) device="$2"; shift 2 ;;
    --rate-mbit) rate_mbit="$2"; shift 2 ;;
    --delay-ms) delay_ms="$2"; shift 2 ;;
    --fps-target) fps_target="$2"; shift 2 ;;
    --seconds) seconds="$2"; shift 2 ;;
    --view) view="$2"; shift 2 ;;
    --view-jumps) view_jumps="$2"; shift 2 ;;
    --dwell) dwell="$2"; shift 2 ;;
    --pause-wait) pause_wait="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    *) echo "$usage" >&2; exit 2 ;;
  esac
done

build=${LINK_BENCH_BUILD:-build/release}  # another build's binaries, to compare two versions
server_bin="$build/server/dysa-server"
cli_bin="$build/clients/cli/dysa"
relay_bin="$build/tests/dysa-delay-relay"
view_bin="$build/bench/view_link_bench"
bins=("$server_bin" "$cli_bin" "$relay_bin")
(( view_jumps > 0 )) && bins+=("$view_bin")
for bin in "${bins[@]}"; do
  [[ -x "$bin" ]] || { echo "link_watch_bench: $bin missing; build it first" >&2; exit 1; }
done

work="$(mktemp -d)"
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
mkdir -p "$out"

# gpu_bench's dam break: a 0.5 x 1 x 0.5 m column in a 2 x 1.25 x 0.5 m tank, at the spacing
# that gives the size; a frame is 1/6000 s of flow (time_scale 0.01), a few steps.
python3 - "$work/scene.json" "$particles" <<'PY'
import json, sys
n = int(sys.argv[2])
d = (0.5 * 1.0 * 0.5 / n) ** (1 / 3)
scene = {
    "name": f"link_dam_break_{n}",
    "description": "gpu_bench's 3D dam break, watched over a shaped link (link_watch_bench)",
    "domain": {"min": [0, 0, 0], "max": [2, 1.25, 0.5], "no_slip": [False, True, False]},
    "fluid_blocks": [{"center": [0.25, 0.5, 0.25], "size": [0.5, 1.0, 0.5]}],
    "solver": "wcsph",
    "params": {"gravity": -9.81, "particle_spacing": d, "speed_of_sound": 30,
               "kinematic_viscosity": 1e-6, "time_scale": 0.01},
}
json.dump(scene, open(sys.argv[1], "w"))
PY

"$server_bin" --scene "$work/scene.json" --device "$device" --listen 127.0.0.1:0 \
  --port-file "$work/port" --frame-rate 0 --max-particles 500000000 \
  > "$work/server.txt" 2>&1 &
pids+=($!)
for _ in $(seq 600); do [[ -s "$work/port" ]] && break; sleep 0.5; done
[[ -s "$work/port" ]] || { echo "link_watch_bench: the server did not start"; cat "$work/server.txt"; exit 1; }
server="127.0.0.1:$(cat "$work/port")"
status_json() { "$cli_bin" --server "$server" --json status; }
field() { python3 -c "import json,sys; print(json.load(sys.stdin)$1)"; }

# The simulated frame rate nobody watches: frames over 5 s, or over 3 frames where they are
# slower (100 M particles: ~10 s a frame), from one frame's start to another's.
sleep 3
wait_frame() {  # prints the first frame number above $1, once it shows (120 s at most)
  local f
  for _ in $(seq 1200); do
    f=$(status_json | field "['frame']")
    [[ "$f" -gt "$1" ]] && { echo "$f"; return; }
    sleep 0.1
  done
  echo "$f"
}
f0=$(wait_frame "$(status_json | field "['frame']")"); t0=$(date +%s.%N)
status_json > "$work/status_alone_0.json"
sleep 5
f1=$(status_json | field "['frame']")
if (( f1 < f0 + 3 )); then f1=$(wait_frame $((f0 + 2))); fi
t1=$(date +%s.%N)
status_json > "$work/status_alone_1.json"
alone=$(python3 -c "print(($f1 - $f0) / ($t1 - $t0))")
n_real=$(status_json | field "['particles']")
echo "link_watch_bench: $n_real particles on $device: $alone frames/s unwatched"

"$relay_bin" --listen 127.0.0.1:0 --upstream "$server" --delay-ms "$delay_ms" \
  --rate-mbit "$rate_mbit" --max-queue-mib 4 --port-file "$work/relay_port" > "$work/relay.txt" 2>&1 &
pids+=($!)
for _ in $(seq 100); do [[ -s "$work/relay_port" ]] && break; sleep 0.1; done
relay="127.0.0.1:$(cat "$work/relay_port")"

view_flag=()
[[ -n "$view" ]] && view_flag=(--view ${view//,/ })
"$cli_bin" --server "$relay" --json watch --fps-target "$fps_target" --seconds "$seconds" \
  "${view_flag[@]}" > "$work/watch.json" 2> "$work/watch_err.txt" &
watch_pid=$!
gpu=cpu
if [[ "$device" == cuda* ]]; then
  gpu=$(nvidia-smi --query-gpu=name --format=csv,noheader | head -n 1 | tr -c 'A-Za-z0-9\n' '_')
fi
samples="$out/link_watch_${particles}_${rate_mbit}mbit_${gpu}.txt"
{ echo "# bench/link_watch_bench.sh --particles $particles --device $device --rate-mbit $rate_mbit --delay-ms $delay_ms --fps-target $fps_target --seconds $seconds"
  echo "# $n_real particles, $alone frames/s unwatched; the server's stream status once a second while watched"; } > "$samples"
for k in $(seq "$seconds"); do
  sleep 1
  # The first and the last sample's whole status: the stages' times while watched.
  status_json > "$work/status.json" || continue
  [[ $k -eq 2 ]] && cp "$work/status.json" "$work/status_watched_0.json"
  cp "$work/status.json" "$work/status_watched_1.json"
  python3 -c "import json,sys; s=json.load(sys.stdin); import time; print(json.dumps({'t': time.time(), 'frame': s['frame'], **(s['streams'][0] if s['streams'] else {})}))" < "$work/status.json" >> "$samples" || true
done
wait "$watch_pid" || { echo "link_watch_bench: watch failed"; cat "$work/watch_err.txt"; exit 1; }
cat "$samples"

python3 - "$work/watch.json" "$samples" "$out/link_watch_${gpu}.csv" "$n_real" "$device" \
  "$rate_mbit" "$delay_ms" "$fps_target" "$alone" "$work" <<'PY'
import json, os, sys
watch = json.load(open(sys.argv[1]))
samples, csv = sys.argv[2], sys.argv[3]
n, device, rate, delay, target, alone = sys.argv[4:10]
alone = float(alone)
work = sys.argv[10]


def per_frame(before, after):
    """Each stage's milliseconds per simulated frame between two statuses (the solver's passes
    summed as "solver"): from the passes' mean times their calls, so a window's own average."""
    a, b = (json.load(open(os.path.join(work, f))) for f in (before, after))
    frames = b["frame"] - a["frame"]
    if frames <= 0:
        return {}
    total = lambda s: {p["name"]: p["mean_ms"] * p["calls"] for p in s["passes"]}
    ta, tb = total(a), total(b)
    stages = {"solver": 0.0}
    for name, ms in tb.items():
        # A stage that first ran inside the window (gather, publish) started from zero.
        d = (ms - ta.get(name, 0.0)) / frames
        if name in ("keep_frame_start", "record_history", "gather_frames", "publish_frames"):
            stages[name] = d
        else:
            stages["solver"] += d
    return stages


alone_ms = per_frame("status_alone_0.json", "status_alone_1.json")
watched_ms = per_frame("status_watched_0.json", "status_watched_1.json")
with open(samples, "a") as f:
    f.write("# ms per simulated frame, unwatched: %s\n" % json.dumps(alone_ms))
    f.write("# ms per simulated frame, watched: %s\n" % json.dumps(watched_ms))
# The samples taken while the stream was open: its age, and the simulated frame rate meanwhile.
streamed = [json.loads(line) for line in open(samples) if line.startswith("{")]
streamed = [x for x in streamed if "age_s" in x]
ages = [1000 * x["age_s"] for x in streamed]
watched = 0.0
if len(streamed) >= 2:
    watched = (streamed[-1]["frame"] - streamed[0]["frame"]) / (streamed[-1]["t"] - streamed[0]["t"])
received = watch["frames_per_second"]
row = {
    "particles": n, "device": device, "rate_mbit": rate, "delay_ms": delay, "fps_target": target,
    "simulated_fps_unwatched": f"{alone:.2f}", "simulated_fps_watched": f"{watched:.2f}",
    "slowdown": f"{(alone - watched) / alone:.3f}" if alone > 0 else "",
    "received_fps": f"{received:.2f}",
    "first_frame_s": f"{watch.get('first_frame_s', -1):.2f}",
    "received_share_of_simulated": f"{received / watched:.3f}" if watched > 0 else "",
    "particles_per_frame": watch["particles"], "detail": f"{watch['detail']:.4f}",
    "bytes_per_frame": f"{watch['bytes_per_frame']:.0f}",
    "mbit_per_s": f"{watch['bytes_per_frame'] * received * 8 / 1e6:.1f}",
    "age_ms_median": f"{sorted(ages)[len(ages) // 2]:.0f}" if ages else "",
    "age_ms_max": f"{max(ages):.0f}" if ages else "",
    "frames_skipped": watch["frames_skipped"],
    # Where a frame's time goes, per simulated frame (the status's stages): the solver's passes,
    # a long frame's kept start, the history's bookkeeping, and while watched the subset's read and (on the publishing
    # thread, beside the stepping) its encoding.
    "solver_ms_unwatched": f"{alone_ms.get('solver', 0):.2f}",
    "solver_ms_watched": f"{watched_ms.get('solver', 0):.2f}",
    "keep_start_ms_unwatched": f"{alone_ms.get('keep_frame_start', 0):.2f}",
    "keep_start_ms_watched": f"{watched_ms.get('keep_frame_start', 0):.2f}",
    "history_ms_unwatched": f"{alone_ms.get('record_history', 0):.2f}",
    "history_ms_watched": f"{watched_ms.get('record_history', 0):.2f}",
    "gather_ms": f"{watched_ms.get('gather_frames', 0):.2f}",
    "publish_ms_per_simulated_frame": f"{watched_ms.get('publish_frames', 0):.2f}",
}
header = ",".join(row)
if os.path.exists(csv):
    lines = open(csv).read().splitlines()
    if lines and lines[0] != header:
        # Rows of an older bench: their columns by name, blank where they had none.
        old = lines[0].split(",")
        with open(csv, "w") as f:
            f.write(header + "\n")
            for line in lines[1:]:
                values = dict(zip(old, line.split(",")))
                f.write(",".join(values.get(k, "") for k in row) + "\n")
else:
    with open(csv, "w") as f:
        f.write(header + "\n")
with open(csv, "a") as f:
    f.write(",".join(str(v) for v in row.values()) + "\n")
print(", ".join(f"{k} {v}" for k, v in row.items()))
PY

if (( view_jumps > 0 )); then
  # The same link, a camera that jumps: the new view's arrival and, paused, the complete frame.
  "$view_bin" --server "$relay" --fps-target "$fps_target" --jumps "$view_jumps" --dwell "$dwell" \
    --pause-wait "$pause_wait" \
    --label "${n_real}_${rate_mbit}mbit_${delay_ms}ms" --csv "$out/view_link_${gpu}.csv" \
    | tee -a "$samples"
fi
