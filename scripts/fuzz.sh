#!/usr/bin/env bash
# Fuzzes the frame decoder with libFuzzer: scripts/fuzz.sh [SECONDS] [libFuzzer flags...]
#
#   scripts/fuzz.sh            60 s
#   scripts/fuzz.sh 600        10 min
#   scripts/fuzz.sh 300 -seed=1 -use_value_profile=1
#
# Environment: FUZZ_NO_SANITIZE (below) and the harness's DYSA_FUZZ_* switches, which let a run go
# on past a known finding (fuzz/frame_decoder_fuzzer.cc lists them).
# A developer tool, not part of scripts/test.sh. Installs what it needs (scripts/setup.sh and
# FUZZ_PACKAGES below), builds frame_decoder_fuzzer with Clang in build/fuzz (its own build
# directory; the project's other builds use GCC), and fuzzes a working corpus in build/fuzz/corpus
# that starts as a copy of the seeds in fuzz/corpus and keeps what earlier runs found.
# Crash, leak, OOM and timeout inputs go to build/fuzz/artifacts/; the log to build/fuzz/fuzz.log.
# Exits non-zero when the fuzzer reports anything. See fuzz/README.md.
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."

seconds="${1:-60}"
if [[ ! "$seconds" =~ ^[0-9]+$ || "$seconds" -lt 1 ]]; then
  echo "usage: scripts/fuzz.sh [SECONDS] [libFuzzer flags...]" >&2
  exit 2
fi
shift || true

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
CC=clang CXX=clang++ cmake -S . -B "$build" "${generator[@]}" -DDYSA_FUZZ=ON \
  -DDYSA_BUILD_TESTS=OFF -DDYSA_BUILD_BENCH=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DDYSA_FUZZ_NO_SANITIZE="${FUZZ_NO_SANITIZE:-}" > /dev/null
cmake --build "$build" --target frame_decoder_fuzzer make_corpus -j"$(nproc)"

fuzzer="$build/fuzz/frame_decoder_fuzzer"
corpus="$build/corpus"
artifacts="$build/artifacts"
log="$build/fuzz.log"
mkdir -p "$corpus" "$artifacts"
cp fuzz/corpus/* "$corpus"/

# One OpenMP thread: runs are reproducible, and the decoder's parallel chunk loop is not what
# ASan can check anyway (a data race needs ThreadSanitizer).
export OMP_NUM_THREADS=1
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"

echo "fuzz.sh: fuzzing for ${seconds} s ($(ls "$corpus" | wc -l) inputs in $corpus); log: $log"
status=0
"$fuzzer" "$corpus" -max_total_time="$seconds" -max_len=1048576 -rss_limit_mb=2048 \
  -timeout=60 -print_final_stats=1 -artifact_prefix="$artifacts/" "$@" > "$log" 2>&1 || status=$?

# The last status line (#N DONE cov: ... exec/s: ...) and the final statistics.
grep -E '^#[0-9]+' "$log" | tail -n 1 || true
grep -E '^stat::' "$log" || true
if [[ $status -eq 0 ]] && grep -qE 'ERROR: (AddressSanitizer|LeakSanitizer|libFuzzer)|runtime error:|FINDING:' "$log"; then
  status=1
fi
if [[ $status -ne 0 ]]; then
  echo "fuzz.sh: FAILED: the fuzzer reported a problem (exit status $status):" >&2
  grep -E -A 30 'ERROR: |runtime error:|FINDING:' "$log" | head -n 60 >&2 || tail -n 40 "$log" >&2
  ls -1 "$artifacts" >&2
  echo "fuzz.sh: reproduce with: OMP_NUM_THREADS=1 DYSA_FUZZ_VERBOSE=1 $fuzzer ARTIFACT" >&2
  exit "$status"
fi
echo "fuzz.sh: PASSED: nothing found in ${seconds} s"
