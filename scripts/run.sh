#!/usr/bin/env bash
# The main job: simulates the thesis's test scene (seed_test_scene, 91,125 particles) offline
# for 2 simulated seconds, showing a progress line on a terminal and printing the per-pass
# timing table; probes go to out/seed_test_scene/probes.csv.
#
#   scripts/run.sh                    # as above
#   scripts/run.sh --vtk-every 5      # extra arguments go to `dysa run` (see `dysa run --help`)
#   scripts/run.sh --steps 20         # --steps/--end-time/--out replace the defaults below
#
# Installs missing packages and builds the release preset first.
#
# TODO(later issue): this becomes "start dysa-server with the scene and open dysa-viewer on it";
# the offline run stays available as `dysa run`.
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."

scripts/build.sh release

# Defaults, each left out when the caller gives the same option (dysa rejects an option given
# twice, and --end-time together with --steps).
defaults_time=(--end-time 2)
defaults_out=(--out out/seed_test_scene)
for arg in "$@"; do
  case "$arg" in
    --steps | --steps=* | --end-time | --end-time=*) defaults_time=() ;;
    --out | --out=*) defaults_out=() ;;
  esac
done

exec build/release/clients/cli/dysa run seed_test_scene \
  "${defaults_time[@]}" "${defaults_out[@]}" "$@"
