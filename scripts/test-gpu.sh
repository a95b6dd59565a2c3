#!/usr/bin/env bash
# On a machine with an NVIDIA GPU: builds with the CUDA backend, runs the GPU tests
# (ctest -L gpu, which must run there, not skip), the GPU benchmarks (gpu_bench for the three
# solvers, server_bench --part gpu and --part gpu_watch), and `dysa validate` (--quick, and at the default
# resolutions without --quick) on the CPU and on the GPU, whose errors must agree within 0.2
# points (scripts/compare-validation.py). Everything is
# written under OUT_DIR, each file named after the GPU.
#
#   scripts/test-gpu.sh [OUT_DIR] [--quick]        (default OUT_DIR: bench/results)
#
#   --quick   the benchmarks at 91,125 and 1 M particles only
#
# On Debian 12 it installs the packages first (scripts/setup.sh). Elsewhere (a GPU machine
# without Debian's packages, bench/README.md "GPU") set DYSA_DEPS to a prefix holding them
# (CMake packages under $DYSA_DEPS/usr, protoc in $DYSA_DEPS/usr/bin). The build directory is
# build/gpu (DYSA_GPU_BUILD to change it); DYSA_CUDA_ARCHITECTURES narrows the GPU code built
# (default: every architecture of CMakeLists.txt).
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."

out="bench/results"
quick=0
for arg in "$@"; do
  case "$arg" in
    --quick) quick=1 ;;
    -*)
      echo "usage: scripts/test-gpu.sh [OUT_DIR] [--quick]" >&2
      exit 2
      ;;
    *) out="$arg" ;;
  esac
done
build="${DYSA_GPU_BUILD:-build/gpu}"

if ! command -v nvidia-smi > /dev/null 2>&1 || ! nvidia-smi -L > /dev/null 2>&1; then
  echo "test-gpu.sh: no NVIDIA GPU here (nvidia-smi is missing or lists no GPU); the GPU tests" \
    "need one. CI and machines without a GPU run scripts/test.sh, where they skip." >&2
  exit 1
fi

configure=(-S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DDYSA_CUDA=ON -DDYSA_VIEWER=OFF)
if [[ -n "${DYSA_DEPS:-}" ]]; then
  configure+=(-DCMAKE_PREFIX_PATH="$DYSA_DEPS/usr"
    -DProtobuf_PROTOC_EXECUTABLE="$DYSA_DEPS/usr/bin/protoc")
else
  scripts/setup.sh
fi
if [[ -n "${DYSA_CUDA_ARCHITECTURES:-}" ]]; then
  configure+=(-DDYSA_CUDA_ARCHITECTURES="$DYSA_CUDA_ARCHITECTURES")
fi
if [[ ! -f "$build/CMakeCache.txt" ]] && command -v ninja > /dev/null 2>&1; then
  configure+=(-G Ninja)
fi
cmake "${configure[@]}"
cmake --build "$build" -j"$(nproc)"

gpu=$(nvidia-smi --query-gpu=name --format=csv,noheader | head -n 1 | tr -c 'A-Za-z0-9\n' '_')
mkdir -p "$out"
status=0

# The GPU tests: every one must run here; a skip means the GPU could not be used.
tests_log="$out/gpu_tests_$gpu.txt"
{
  nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader
  ctest --test-dir "$build" -L gpu --output-on-failure --timeout 600
} 2>&1 | tee "$tests_log" || status=1
if grep -q "Skipped" "$tests_log" || grep -q "\[  SKIPPED \]" "$tests_log"; then
  echo "test-gpu.sh: FAILED: GPU tests skipped on a machine with a GPU" >&2
  status=1
fi

# The benchmarks: every solver from 91,125 particles up (the CPU in the same run up to 1 M),
# and the server streaming from the GPU to a subscriber on this machine.
sizes="91125,1000000,10000000,100000000"
physical_sizes="91125,1000000,10000000"
server_sizes="1000000,10000000"
if [[ $quick -eq 1 ]]; then
  sizes="91125,1000000" physical_sizes="91125,1000000" server_sizes="1000000"
fi
export OMP_WAIT_POLICY=PASSIVE
"$build/bench/gpu_bench" --sizes "$sizes" --physical-sizes "$physical_sizes" --cpu-max 1000000 \
  --out "$out" 2>&1 | tee "$out/gpu_bench_$gpu.txt" || status=1
"$build/bench/server_bench" --part gpu --gpu-sizes "$server_sizes" --seconds 5 --out "$out" 2>&1 |
  tee "$out/server_gpu_$gpu.txt" || status=1
# What a budgeted stream watching the run costs its step rate (the subset chosen on the GPU).
"$build/bench/server_bench" --part gpu_watch --gpu-sizes "$server_sizes" --watch-percent 1 \
  --watch-rounds 3 --seconds 5 --out "$out" 2>&1 | tee "$out/server_gpu_watch_$gpu.txt" || status=1

# The validation cases on both devices: the same errors within 0.2 points. A missed accuracy
# target (dysa validate's exit status) is the solver's, on both devices alike, not the GPU's:
# the comparison decides here (it also fails when an output lacks a row).
"$build/clients/cli/dysa" validate --quick --device cpu > "$out/validate_quick_cpu_$gpu.txt" 2>&1 ||
  true
"$build/clients/cli/dysa" validate --quick --device cuda > "$out/validate_quick_cuda_$gpu.txt" 2>&1 ||
  true
python3 scripts/compare-validation.py "$out/validate_quick_cpu_$gpu.txt" \
  "$out/validate_quick_cuda_$gpu.txt" --max-points 0.2 2>&1 |
  tee "$out/validate_quick_cpu_vs_cuda_$gpu.txt" || status=1
# And at the default resolutions (about 2 minutes on 16 cores), unless --quick.
if [[ $quick -eq 0 ]]; then
  for device in cpu cuda; do
    "$build/clients/cli/dysa" validate --device "$device" > "$out/validate_default_${device}_$gpu.txt" \
      2>&1 || true
  done
  python3 scripts/compare-validation.py "$out/validate_default_cpu_$gpu.txt" \
    "$out/validate_default_cuda_$gpu.txt" --max-points 0.2 2>&1 |
    tee "$out/validate_default_cpu_vs_cuda_$gpu.txt" || status=1
fi

if [[ $status -eq 0 ]]; then
  echo "test-gpu.sh: PASSED ($gpu)"
else
  echo "test-gpu.sh: FAILED ($gpu)" >&2
fi
exit "$status"
