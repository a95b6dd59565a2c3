#!/usr/bin/env bash
# Fuzzes the project's parsers with libFuzzer: scripts/fuzz.sh [SECONDS] [TARGET] [libFuzzer flags...]
#
#   scripts/fuzz.sh                        every target, 60 s each
#   scripts/fuzz.sh 600                    every target, 10 min each
#   scripts/fuzz.sh 300 scene_parser       one target (TARGET or TARGET_fuzzer)
#   scripts/fuzz.sh 300 -seed=1 -use_value_profile=1
#
# Targets (fuzz/README.md): frame_decoder, scene_parser, param_assignment, service_request.
# Environment: FUZZ_NO_SANITIZE (below) and the decoder harness's DYSA_FUZZ_* switches, which let
# a run go on past a known finding (fuzz/frame_decoder_fuzzer.cc lists them).
# A developer tool, not part of scripts/test.sh. Installs what it needs (scripts/setup.sh and
# FUZZ_PACKAGES below), builds the fuzzers with Clang in build/fuzz (its own build directory; the
# project's other builds use GCC), and fuzzes each target's working corpus in
# build/fuzz/corpus/TARGET, which starts as a copy of its seeds in fuzz/corpus/TARGET and keeps
# what earlier runs found. The targets run one after the other, one process each (-jobs=1).
# Crash, leak, OOM and timeout inputs go to build/fuzz/artifacts/TARGET/; the logs to
# build/fuzz/TARGET.log. Exits non-zero when a fuzzer reports anything. See fuzz/README.md.
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."

usage="usage: scripts/fuzz.sh [SECONDS] [TARGET] [libFuzzer flags...]"
all_targets=(frame_decoder scene_parser param_assignment service_request)
seconds="${1:-60}"
if [[ ! "$seconds" =~ ^[0-9]+$ || "$seconds" -lt 1 ]]; then
  echo "$usage" >&2
  exit 2
fi
shift || true
targets=("${all_targets[@]}")
if [[ $# -gt 0 && "$1" != -* ]]; then
  target="${1%_fuzzer}"
  if [[ ! " ${all_targets[*]} " =~ " $target " ]]; then
    echo "$usage" >&2
    echo "fuzz.sh: unknown target '$1'; targets: ${all_targets[*]}" >&2
    exit 2
  fi
  targets=("$target")
  shift
fi

# Packages only fuzzing needs, on top of scripts/setup.sh: Clang, its libFuzzer and sanitizer
# runtimes, and LLVM's OpenMP (Clang's -fopenmp links libomp, not GCC's libgomp).
FUZZ_PACKAGES=(
  clang
  libclang-rt-14-dev
  libomp-14-dev
)

scripts/setup.sh
missing=()
for pkg in "${FUZZ_PACKAGES[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null || true)
  if [[ "$status" != "install ok installed" ]]; then
    missing+=("$pkg")
  fi
done
if [[ ${#missing[@]} -gt 0 ]]; then
  if [[ $(id -u) -ne 0 ]]; then
    echo "fuzz.sh: missing Debian packages: ${missing[*]}; run as root or install them" >&2
    exit 1
  fi
  echo "fuzz.sh: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update
  apt-get install -y --no-install-recommends "${missing[@]}"
fi

build=build/fuzz
generator=()
if [[ ! -f "$build/CMakeCache.txt" ]]; then
  if command -v ninja > /dev/null 2>&1; then
    generator=(-G Ninja)
  else
    generator=(-G "Unix Makefiles")
  fi
fi
# FUZZ_NO_SANITIZE=pointer-overflow (say) leaves UBSan checks out, to fuzz on past a known finding.
# No CUDA backend: nvcc takes no sanitizer flags, and the parsers do not depend on it.
CC=clang CXX=clang++ cmake -S . -B "$build" "${generator[@]}" -DDYSA_FUZZ=ON \
  -DDYSA_BUILD_TESTS=OFF -DDYSA_BUILD_BENCH=OFF -DDYSA_CUDA=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DDYSA_FUZZ_NO_SANITIZE="${FUZZ_NO_SANITIZE:-}" > /dev/null
build_targets=()
for target in "${targets[@]}"; do build_targets+=("${target}_fuzzer"); done
# The seed writers (fuzz/README.md, "Seeds"), to rewrite the seeds after a format change.
[[ " ${targets[*]} " =~ " frame_decoder " ]] && build_targets+=(make_corpus)
[[ " ${targets[*]} " =~ " service_request " ]] && build_targets+=(make_service_corpus)
cmake --build "$build" --target "${build_targets[@]}" -j"$(nproc)"

# One OpenMP thread: runs are reproducible, and the decoder's parallel chunk loop is not what
# ASan can check anyway (a data race needs ThreadSanitizer).
export OMP_NUM_THREADS=1
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"

# The longest input per target: a frame stream of a few chunks; a scene file as big as the
# largest hostile seed; one --set value; a few requests (each record is at most 64 KiB).
declare -A max_len=([frame_decoder]=1048576 [scene_parser]=262144 [param_assignment]=8192
                    [service_request]=65536)
# The service's host allocates on its own threads, so nearly every input ends with mallocs and
# frees unbalanced and libFuzzer would run it again under a full leak scan (2.3x slower); leaks
# are still checked when the process exits.
declare -A target_flags=([service_request]="-detect_leaks=0")

# Runs one target; returns non-zero on any finding.
fuzz_target() {
  local target="$1"
  shift
  local fuzzer="$build/fuzz/${target}_fuzzer"
  local corpus="$build/corpus/$target"
  local artifacts="$build/artifacts/$target"
  local log="$build/$target.log"
  mkdir -p "$corpus" "$artifacts"
  cp fuzz/corpus/"$target"/* "$corpus"/

  echo "fuzz.sh: $target for ${seconds} s ($(ls "$corpus" | wc -l) inputs in $corpus); log: $log"
  local status=0
  "$fuzzer" "$corpus" -max_total_time="$seconds" -max_len="${max_len[$target]}" \
    -rss_limit_mb=2048 -timeout=60 -print_final_stats=1 -artifact_prefix="$artifacts/" ${target_flags[$target]:-} "$@" \
    > "$log" 2>&1 || status=$?

  # The last status line (#N DONE cov: ... exec/s: ...) and the final statistics.
  grep -E '^#[0-9]+' "$log" | tail -n 1 || true
  grep -E '^stat::' "$log" || true
  if [[ $status -eq 0 ]] &&
     grep -qE 'ERROR: (AddressSanitizer|LeakSanitizer|libFuzzer)|runtime error:|FINDING:' "$log"; then
    status=1
  fi
  if [[ $status -ne 0 ]]; then
    echo "fuzz.sh: $target FAILED: the fuzzer reported a problem (exit status $status):" >&2
    grep -E -A 30 'ERROR: |runtime error:|FINDING:' "$log" | head -n 60 >&2 || tail -n 40 "$log" >&2
    ls -1 "$artifacts" >&2
    echo "fuzz.sh: reproduce with: OMP_NUM_THREADS=1 $fuzzer ARTIFACT" >&2
    return "$status"
  fi
  echo "fuzz.sh: $target PASSED: nothing found in ${seconds} s"
}

failed=()
for target in "${targets[@]}"; do
  fuzz_target "$target" "$@" || failed+=("$target")
done
if [[ ${#failed[@]} -gt 0 ]]; then
  echo "fuzz.sh: FAILED: ${failed[*]}" >&2
  exit 1
fi
echo "fuzz.sh: PASSED: ${targets[*]}"
