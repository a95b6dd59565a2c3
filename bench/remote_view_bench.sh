#!/usr/bin/env bash
# What a particle budget costs and what it shows (issue 32, item 7): the same frame of a
# 1,000,000-particle scene from the same camera (the viewer's default view), at full detail and
# at particle budgets of 100, 30, 10, 3 and 1 percent, plus the detail a 100 Mbit/s link holds
# at 30 frames/s. Per detail: bytes per keyframe and delta frame, the frame rate they allow on
# 100 Mbit/s and 1 Gbit/s, the viewer's render rate (Xvfb + Mesa llvmpipe: this machine's CPU,
# not a GPU), SSIM against full detail and the largest screen gap between drawn particles.
#
#   bench/remote_view_bench.sh [--frames N] [--per-axis P] [--mode particles|fluid]
#                              [--percent 100,30,10,3,1] [--link-mbit 100] [--fps 30] [--tag T]
#
# --link-mbit and --fps name the link row (the detail that link holds at that frame rate);
# --tag T names the outputs remote_view_T* instead (e.g. a 10 M block: --per-axis 215 --tag 10m).
#
# Writes bench/results/remote_view[_MODE].csv, remote_view[_MODE]_gather.csv (the server's cost
# of copying and encoding a frame at each detail), remote_view[_MODE]_sheet.png (the renderings,
# 3 per row, in the CSV's order), remote_view[_MODE]_full.png and remote_view[_MODE]_1percent.png
# (full detail and the 1 % rendering).
# Needs a release build of dysa-server, dysa, dysa-viewer and remote_view_bench.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

frames=24
per_axis=100
mode=particles
percent=100,30,10,3,1
link_mbit=100
fps=30
tag=""
width=1280
height=800
while [[ $# -gt 0 ]]; do
  case "$1" in
    --frames) frames="$2"; shift 2 ;;
    --per-axis) per_axis="$2"; shift 2 ;;
    --mode) mode="$2"; shift 2 ;;
    --percent) percent="$2"; shift 2 ;;
    --link-mbit) link_mbit="$2"; shift 2 ;;
    --fps) fps="$2"; shift 2 ;;
    --tag) tag="$2"; shift 2 ;;
    *) echo "usage: bench/remote_view_bench.sh [--frames N] [--per-axis P] [--mode particles|fluid] [--percent LIST] [--link-mbit M] [--fps F] [--tag T]" >&2
       exit 2 ;;
  esac
done

build=build/release
server_bin="$build/server/dysa-server"
cli_bin="$build/clients/cli/dysa"
viewer_bin="$build/viewer/dysa-viewer"
bench_bin="$build/bench/remote_view_bench"
for bin in "$server_bin" "$cli_bin" "$viewer_bin" "$bench_bin"; do
  [[ -x "$bin" ]] || { echo "remote_view_bench: $bin missing; build it first" >&2; exit 1; }
done

work="$(mktemp -d)"
server_pid=""
cleanup() {
  [[ -n "$server_pid" ]] && kill "$server_pid" 2>/dev/null && wait "$server_pid" 2>/dev/null
  rm -rf "$work"
}
trap cleanup EXIT
mkdir -p bench/results

# The thesis fluid as a P^3 block (as viewer_bench and codec_bench build it) in the middle
# of a box twice its width: after a few frames it has fallen onto the floor and begun to spread.
/usr/bin/python3 - "$work/block.json" "$per_axis" <<'PY'
import json, sys
n = int(sys.argv[2])
size = 5.0 / 44 * (n - 1)
scene = {
    "name": f"falling_block_{n}^3",
    "description": "The thesis fluid as a block falling in a box (remote_view_bench)",
    "domain": {"min": [-size, -size, -size], "max": [size, size, size]},
    "fluid_blocks": [{"center": [0, 0, 0], "seed": 1}],
    "params": {"time_scale": 0.8, "iterations_per_frame": 2, "collision_damping": 0.118,
               "smoothing_radius": 0.3, "pressure_multiplier": 58.8,
               "near_pressure_multiplier": 28.88, "particle_quantity": n,
               "spawn_size": size, "spawn_jitter": 0.32},
}
json.dump(scene, open(sys.argv[1], "w"))
PY

suffix=""
[[ -n "$tag" ]] && suffix="_$tag"
[[ "$mode" == particles ]] || suffix="${suffix}_$mode"
echo "remote_view_bench: bytes per frame at each detail (frame $frames) ..."
"$bench_bin" bytes --scene "$work/block.json" --frames "$frames" --percent "$percent" \
  --link-mbit "$link_mbit" --fps "$fps" > "$work/bytes.csv"
cat "$work/bytes.csv"
echo "remote_view_bench: the server's cost of a frame at each detail ..."
# Passive OpenMP waits: spinning threads on a shared 2-core machine swamp the small encodes.
OMP_WAIT_POLICY=PASSIVE "$bench_bin" gather --scene "$work/block.json" --repeats 15 \
  --percent "$percent" > "bench/results/remote_view${suffix}_gather.csv"
cat "bench/results/remote_view${suffix}_gather.csv"

"$server_bin" --scene "$work/block.json" --paused --listen 127.0.0.1:0 --port-file "$work/port" \
  >"$work/server.log" 2>&1 &
server_pid=$!
for _ in $(seq 600); do [[ -s "$work/port" ]] && break; sleep 0.1; done
[[ -s "$work/port" ]] || { cat "$work/server.log" >&2; exit 1; }
address="127.0.0.1:$(cat "$work/port")"
if [[ "$frames" -gt 0 ]]; then
  "$cli_bin" --server "$address" step "$frames" >/dev/null
fi
# The same frame as `bytes` encoded: wait until the server is there.
for _ in $(seq 3000); do
  frame="$("$cli_bin" --server "$address" status --json | /usr/bin/python3 -c \
    'import json, sys; print(json.load(sys.stdin)["frame"])')"
  [[ "$frame" -ge "$frames" ]] && break
  sleep 0.2
done
echo "remote_view_bench: server at frame $frame"

shot() {  # shot PNG [viewer options...]: prints the viewer's render rate and particles drawn
  local png="$1"; shift
  local line
  line="$(xvfb-run -a -s "-screen 0 ${width}x${height}x24" "$viewer_bin" --server "$address" \
    --screenshot "$png" --frames 5 --width "$width" --height "$height" --mode "$mode" \
    --timeout 300 "$@")"
  echo "$line" >&2
  # The paused server completes a view stream's frame progressively: a slow rendering may draw
  # a refinement or two beyond the budget, so the particles drawn are recorded beside it.
  sed -E 's/.*, ([0-9]+) particles\): .* s, ([0-9.]+) frames\/s.*/\2,\1/' <<<"$line"
}

shot "$work/full.png" >/dev/null
cp "$work/full.png" "bench/results/remote_view${suffix}_full.png"
header="$(head -1 "$work/bytes.csv"),render_fps,drawn_particles"
echo "$header" > "$work/rows.csv"
images=()
index=0
while IFS=, read -r label fraction particles budget rest; do
  index=$((index + 1))
  png="$work/detail_$index.png"
  fps="$(shot "$png" --particle-budget "$budget")"
  images+=("$png")
  echo "$label,$fraction,$particles,$budget,$rest,$fps" >> "$work/rows.csv"
  [[ "$label" == "1%" ]] && cp "$png" "bench/results/remote_view${suffix}_1percent.png"
done < <(tail -n +2 "$work/bytes.csv")

csv="bench/results/remote_view${suffix}.csv"
"$bench_bin" compare --reference "$work/full.png" --csv "$work/rows.csv" \
  --images "$(IFS=,; echo "${images[*]}")" --out "$csv" \
  --sheet "bench/results/remote_view${suffix}_sheet.png"
echo "remote_view_bench: wrote $csv"
column -s, -t "$csv"
