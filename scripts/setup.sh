#!/usr/bin/env bash
# Installs the Debian 12 packages DySAQUASIMs needs to build, test and run.
#
# Idempotent: it installs only what is missing and prints nothing when everything is present.
# Run it as root on a fresh machine; as another user it lists what is missing and fails.
set -euo pipefail

# Every Debian package the project needs, in one place. Add new dependencies here.
PACKAGES=(
  # toolchain
  build-essential
  cmake
  pkg-config
  clang-format
  # C++ libraries
  libeigen3-dev
  nlohmann-json3-dev
  libcli11-dev
  libzstd-dev
  # gRPC service and network clients
  libgrpc++-dev
  libprotobuf-dev
  protobuf-compiler
  protobuf-compiler-grpc
  openssl  # the TLS tests make a self-signed certificate
  # desktop viewer (GLFW, OpenGL 3.3, Dear ImGui) and its headless tests
  libglfw3-dev
  libimgui-dev
  libstb-dev
  libgl1-mesa-dri
  xvfb
  xauth
  xdotool  # the viewer test presses keys
  # MPI ranks for `mpirun -np N dysa run` (docs/distributed.md; optional at build time)
  libopenmpi-dev
  openmpi-bin
  # tests and benchmarks
  libgtest-dev
  libgmock-dev
  libbenchmark-dev
  # Python (bench plots, the Python client and its tests)
  python3
  python3-numpy
  python3-matplotlib
  python3-zstandard
  python3-grpcio
  python3-protobuf
)

missing=()
for pkg in "${PACKAGES[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null || true)
  if [[ "$status" != "install ok installed" ]]; then
    missing+=("$pkg")
  fi
done

if [[ ${#missing[@]} -eq 0 ]]; then
  exit 0
fi

if [[ $(id -u) -ne 0 ]]; then
  echo "setup.sh: missing Debian packages: ${missing[*]}" >&2
  echo "setup.sh: run this script as root (e.g. sudo scripts/setup.sh) or install them with:" >&2
  echo "  apt-get install --no-install-recommends ${missing[*]}" >&2
  exit 1
fi

echo "setup.sh: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update
apt-get install -y --no-install-recommends "${missing[@]}"
