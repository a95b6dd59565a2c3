#!/usr/bin/env bash
# The full validation run whose output docs/validation.md quotes: scripts/validate.sh [--quick] [--out DIR]
#
#   scripts/validate.sh           builds (release), then `dysa validate` at the scenes' own
#                                 resolutions (about 4 minutes on 2 cores) and `dysa validate
#                                 --quick` (the CI test's resolutions and bounds, under a minute)
#   scripts/validate.sh --quick   only the quick run
#   --out DIR                     where the outputs go (default bench/results):
#                                 validate_default.txt, validate_quick.txt
#
# Each output is printed as it is written. Exits 1 when a run misses a target (at the scenes'
# resolutions the dam break's front does, docs/validation.md), 2 for a usage error.
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."

quick_only=0
out_dir="bench/results"
while [[ $# -gt 0 ]]; do
  case "$1" in
    --quick) quick_only=1 ;;
    --out)
      if [[ $# -lt 2 ]]; then
        echo "validate.sh: --out needs a directory" >&2
        exit 2
      fi
      out_dir="$2"
      shift
      ;;
    *)
      echo "usage: scripts/validate.sh [--quick] [--out DIR]" >&2
      exit 2
      ;;
  esac
  shift
done

scripts/build.sh release
mkdir -p "$out_dir"
dysa=build/release/clients/cli/dysa

status=0
run() {  # run NAME [validate options...]
  local name="$1"
  shift
  echo "== dysa validate $* -> $out_dir/$name"
  local rc=0
  "$dysa" validate "$@" | tee "$out_dir/$name" || rc=$?
  if [[ $rc -ne 0 ]]; then status=1; fi
}

run validate_quick.txt --quick
if [[ $quick_only -eq 0 ]]; then run validate_default.txt; fi

if [[ $status -eq 0 ]]; then
  echo "validate.sh: all targets met"
else
  echo "validate.sh: targets missed (see above)"
fi
exit "$status"
