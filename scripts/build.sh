#!/usr/bin/env bash
# Builds one CMake preset: scripts/build.sh [release|asan]   (default: release)
#
#   release  -> build/release   optimised build (what scripts/run.sh and scripts/test.sh use)
#   asan     -> build/asan      AddressSanitizer + UndefinedBehaviorSanitizer, no benchmarks
#
# Installs missing packages first (scripts/setup.sh).
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."

preset="${1:-release}"
case "$preset" in
  release | asan) ;;
  *)
    echo "usage: scripts/build.sh [release|asan]" >&2
    exit 2
    ;;
esac

scripts/setup.sh

# The generator is chosen when a build directory is first configured: Ninja when it is
# installed, otherwise Unix Makefiles. An existing build directory keeps the generator it was
# configured with (CMake refuses to switch generators in place).
generator=()
if [[ ! -f "build/$preset/CMakeCache.txt" ]]; then
  if command -v ninja > /dev/null 2>&1; then
    generator=(-G Ninja)
  else
    generator=(-G "Unix Makefiles")
  fi
fi

cmake --preset "$preset" "${generator[@]}"
cmake --build --preset "$preset" -j"$(nproc)"
