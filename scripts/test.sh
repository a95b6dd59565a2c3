#!/usr/bin/env bash
# Builds and runs the test suite: scripts/test.sh [release|asan] [extra ctest arguments]
#
#   scripts/test.sh          release build (build/release), all tests
#   scripts/test.sh asan     the same suite under AddressSanitizer + UndefinedBehaviorSanitizer
#   scripts/test.sh release -R Scene    only tests matching a regex
#
# Installs missing packages first. Works from a fresh clone (no build directory needed).
# Exits non-zero when the build or any test fails; the last line says which.
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."

preset="release"
if [[ $# -gt 0 && "$1" != -* ]]; then
  preset="$1"
  shift
fi
case "$preset" in
  release | asan) ;;
  *)
    echo "usage: scripts/test.sh [release|asan] [ctest arguments...]" >&2
    exit 2
    ;;
esac

if ! scripts/build.sh "$preset"; then
  echo "test.sh: FAILED: the $preset build failed" >&2
  exit 1
fi

status=0
ctest --preset "$preset" --parallel "$(nproc)" "$@" || status=$?

if [[ $status -eq 0 ]]; then
  echo "test.sh: PASSED ($preset)"
else
  echo "test.sh: FAILED ($preset): ctest exited with status $status" >&2
fi
exit "$status"
