#!/usr/bin/env bash
# Render frames per second of dysa-viewer for the thesis scene (91,125 particles) and a
# 1,000,000-particle block, in both render modes, under Xvfb with Mesa's software OpenGL
# (llvmpipe): the numbers measure the CPU rasteriser of this machine, not a GPU.
#
#   bench/viewer_bench.sh [--frames N] [--width W --height H]
#
# Needs a release build (scripts/build.sh). The server is paused, so every rendered frame
# draws the same particles: this times rendering alone (one upload, then N frames).
# Writes bench/results/viewer.csv and one screenshot per case (bench/results/viewer_*.png).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

frames=60
width=1280
height=800
while [[ $# -gt 0 ]]; do
  case "$1" in
    --frames) frames="$2"; shift 2 ;;
    --width) width="$2"; shift 2 ;;
    --height) height="$2"; shift 2 ;;
    *) echo "usage: bench/viewer_bench.sh [--frames N] [--width W --height H]" >&2; exit 2 ;;
  esac
done

build=build/release
server_bin="$build/server/dysa-server"
viewer_bin="$build/viewer/dysa-viewer"
for bin in "$server_bin" "$viewer_bin"; do
  [[ -x "$bin" ]] || { echo "viewer_bench: $bin missing; run scripts/build.sh first" >&2; exit 1; }
done

work="$(mktemp -d)"
server_pid=""
cleanup() {
  [[ -n "$server_pid" ]] && kill "$server_pid" 2>/dev/null && wait "$server_pid" 2>/dev/null
  rm -rf "$work"
}
trap cleanup EXIT

# The thesis fluid as a 100^3 block: the same spacing (5 m / 44) and parameters, in a box
# scaled to match (as server_bench and codec_bench build it).
/usr/bin/python3 - "$work/block_1m.json" <<'PY'
import json, sys
size = 5.0 / 44 * 99
scene = {
    "name": "block_100^3",
    "description": "The thesis fluid as a 100^3 block (benchmarks)",
    "domain": {"min": [-size] * 3, "max": [size] * 3},
    "fluid_blocks": [{"center": [0, 0, 0], "seed": 1}],
    "params": {"time_scale": 0.8, "iterations_per_frame": 2, "collision_damping": 0.118,
               "smoothing_radius": 0.3, "pressure_multiplier": 58.8,
               "near_pressure_multiplier": 28.88, "particle_quantity": 100,
               "spawn_size": size, "spawn_jitter": 0.32},
}
json.dump(scene, open(sys.argv[1], "w"))
PY

mkdir -p bench/results
csv=bench/results/viewer.csv
echo "scene,particles,mode,width,height,frames,seconds,render_fps" > "$csv"

for scene in seed_test_scene "$work/block_1m.json"; do
  rm -f "$work/port"
  "$server_bin" --scene "$scene" --paused --listen 127.0.0.1:0 --port-file "$work/port" \
    >"$work/server.log" 2>&1 &
  server_pid=$!
  for _ in $(seq 600); do [[ -s "$work/port" ]] && break; sleep 0.1; done
  [[ -s "$work/port" ]] || { cat "$work/server.log" >&2; exit 1; }
  address="127.0.0.1:$(cat "$work/port")"
  name="$(basename "$scene" .json)"
  for mode in particles fluid; do
    line="$(xvfb-run -a -s "-screen 0 ${width}x${height}x24" "$viewer_bin" --server "$address" \
      --screenshot "bench/results/viewer_${name}_${mode}.png" --frames "$frames" \
      --width "$width" --height "$height" --mode "$mode" --timeout 300)"
    echo "$line"
    # "dysa-viewer: wrote F (WxH, MODE, P particles): N frames in S s, R frames/s"
    particles="$(sed -E 's/.*, ([0-9]+) particles.*/\1/' <<<"$line")"
    seconds="$(sed -E 's/.* frames in ([0-9.]+) s.*/\1/' <<<"$line")"
    fps="$(sed -E 's/.* s, ([0-9.]+) frames\/s.*/\1/' <<<"$line")"
    echo "$name,$particles,$mode,$width,$height,$frames,$seconds,$fps" >> "$csv"
  done
  kill "$server_pid"
  wait "$server_pid" || true
  server_pid=""
done
echo "viewer_bench: wrote $csv"
column -s, -t "$csv"
