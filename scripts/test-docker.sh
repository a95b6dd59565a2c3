#!/usr/bin/env bash
# Builds the server's container image (docker/Dockerfile) and checks that `dysa status` on the
# host reaches dysa-server running inside it. Not part of CI (it needs root, podman and a
# network mirror). Usage:
#
#   scripts/test-docker.sh                  # build (cached) and check
#   scripts/test-docker.sh --rebuild-base   # make the Debian base image again first
#   scripts/test-docker.sh --no-cache       # rebuild every layer of the server image
#
# Environment:
#   DYSA_IMAGE          the image to build (default: dysa-server)
#   DYSA_BASE_IMAGE     the Debian 12 base image (default: dysa-debian12-base)
#   DYSA_REBUILD_BASE=1 the same as --rebuild-base
#   DYSA_DEBIAN_MIRROR  the mirror debootstrap uses (default: the bookworm mirror in this
#                       machine's apt sources)
#   DYSA_TEST_PORT      the port the server listens on (default: the first free one from 50551)
#   DYSA_CLI            the host's dysa binary (default: build/release/clients/cli/dysa, built
#                       when missing)
#
# Works with podman and buildah as shipped by Debian 12, without a Docker engine:
#   1. installs podman, buildah, runc and debootstrap when missing (as root);
#   2. makes the base image, when podman does not have it yet: `debootstrap --variant=minbase
#      bookworm` into a temporary directory, then `podman import`;
#   3. builds the image with `podman build` (at nice 19: it compiles dysa-server);
#   4. starts dysa-server in a container (`buildah from` + `buildah run --network host`; plain
#      `podman run` fails on setrlimit in some sandboxes) on 0.0.0.0:PORT with seed_basic;
#   5. runs `dysa --server 127.0.0.1:PORT status` until it answers (60 s at most);
#   6. stops the server with SIGTERM (it must exit 0) and removes the container, also on failure.
# The last line says `test-docker.sh: PASSED` or `test-docker.sh: FAILED: why`.
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."

image="${DYSA_IMAGE:-dysa-server}"
base_image="${DYSA_BASE_IMAGE:-dysa-debian12-base}"
rebuild_base="${DYSA_REBUILD_BASE:-0}"
build_flags=()
for arg in "$@"; do
  case "$arg" in
    --rebuild-base) rebuild_base=1 ;;
    --no-cache) build_flags+=(--no-cache) ;;
    *)
      echo "usage: scripts/test-docker.sh [--rebuild-base] [--no-cache]" >&2
      exit 2
      ;;
  esac
done

fail() {
  echo "test-docker.sh: FAILED: $*" >&2
  exit 1
}

# The runtime and cgroup manager that work here (global podman flags).
podman=(podman --runtime runc --cgroup-manager cgroupfs)

# ---- 1. tools ----------------------------------------------------------------------------------
missing=()
for tool in podman buildah runc debootstrap; do
  command -v "$tool" > /dev/null 2>&1 || missing+=("$tool")
done
if [[ ${#missing[@]} -gt 0 ]]; then
  [[ $(id -u) -eq 0 ]] || fail "missing tools: ${missing[*]} (run as root, or apt-get install them)"
  echo "test-docker.sh: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update
  apt-get install -y --no-install-recommends "${missing[@]}"
fi

# ---- 2. base image -----------------------------------------------------------------------------
# The first bookworm mirror in this machine's apt sources: one-line entries in sources.list and
# sources.list.d/*.list ("deb [options] URI bookworm ..."), then deb822 paragraphs in
# sources.list.d/*.sources (Types: deb, Suites: bookworm, first of URIs, not Enabled: no).
apt_mirror() {
  local files=() f
  for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.list; do
    [[ -f "$f" ]] && files+=("$f")
  done
  if [[ ${#files[@]} -gt 0 ]]; then
    awk '$1 == "deb" {
           i = 2
           if ($i ~ /^\[/) { while (i < NF && $i !~ /\]$/) i++; i++ }
           if ($(i + 1) == "bookworm") { print $i; exit }
         }' "${files[@]}"
  fi
  for f in /etc/apt/sources.list.d/*.sources; do
    [[ -f "$f" ]] || continue
    awk 'BEGIN { RS = ""; FS = "\n" }
         {
           types = ""; suites = ""; uris = ""; enabled = "yes"
           for (n = 1; n <= NF; n++) {
             if ($n ~ /^[ \t]*#/ || $n !~ /:/) continue
             key = tolower(substr($n, 1, index($n, ":") - 1))
             value = " " substr($n, index($n, ":") + 1) " "
             gsub(/[ \t]+/, " ", value)
             if (key == "types") types = value
             else if (key == "suites") suites = value
             else if (key == "uris") uris = value
             else if (key == "enabled") enabled = value
           }
           if (types ~ / deb / && suites ~ / bookworm / && enabled !~ / no /) {
             split(uris, u, " ")
             if (u[1] != "") { print u[1]; exit }
           }
         }' "$f"
  done
}

if [[ "$rebuild_base" == 1 ]] || ! podman image exists "$base_image"; then
  mirror="${DYSA_DEBIAN_MIRROR:-$(apt_mirror | head -n 1)}"
  [[ -n "$mirror" ]] || fail "no bookworm mirror in /etc/apt/sources*; set DYSA_DEBIAN_MIRROR"
  [[ $(id -u) -eq 0 ]] || fail "debootstrap needs root"
  echo "test-docker.sh: making the base image $base_image (debootstrap from $mirror)"
  rootfs="$(mktemp -d /var/tmp/dysa-rootfs.XXXXXX)"
  # Removed however this block ends (the trap is replaced below, once the rootfs is gone).
  trap 'rm -rf "$rootfs"' EXIT
  nice -n 19 debootstrap --variant=minbase bookworm "$rootfs" "$mirror" > "$rootfs.log" 2>&1 ||
    { tail -n 20 "$rootfs.log" >&2; fail "debootstrap failed (log: $rootfs.log)"; }
  rm -f "$rootfs.log"
  # debootstrap leaves its downloads and the package lists; the image needs neither (every RUN
  # that installs packages runs apt-get update first).
  rm -rf "$rootfs"/var/cache/apt/archives/*.deb "$rootfs"/var/lib/apt/lists/*
  if podman image exists "$base_image"; then
    "${podman[@]}" rmi "$base_image" > /dev/null || true
  fi
  tar -C "$rootfs" --numeric-owner --exclude='./dev/*' --exclude='./proc/*' --exclude='./sys/*' \
    -cf - . |
    "${podman[@]}" import \
      --change 'ENV PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin' \
      --change 'CMD ["/bin/bash"]' \
      --message "Debian 12 minbase from $mirror" - "$base_image" > /dev/null
  rm -rf "$rootfs"
  trap - EXIT
fi

# ---- 3. server image ---------------------------------------------------------------------------
echo "test-docker.sh: building $image (podman build, nice 19)"
start=$SECONDS
nice -n 19 "${podman[@]}" build --network host \
  -f docker/Dockerfile --ignorefile docker/Dockerfile.dockerignore \
  --build-arg BASE_IMAGE="$base_image" "${build_flags[@]}" \
  -t "$image" . ||
  fail "podman build failed"
build_seconds=$((SECONDS - start))
size=$("${podman[@]}" image inspect --format '{{.Size}}' "$image")
echo "test-docker.sh: built $image in ${build_seconds}s, $((size / 1000000)) MB"
# The container below runs an explicit command (buildah run ignores ENTRYPOINT and CMD), so the
# image's default command is checked here: dysa-server on 0.0.0.0:50051, port exposed.
config=$("${podman[@]}" image inspect \
  --format '{{.Config.Entrypoint}} {{.Config.Cmd}} {{.Config.ExposedPorts}}' "$image")
[[ "$config" == "[dysa-server] [--listen 0.0.0.0:50051] map[50051/tcp:{}]" ]] ||
  fail "unexpected image command: $config"

# ---- 4. host CLI -------------------------------------------------------------------------------
# Built only when missing: the target alone, in the release build directory.
cli="${DYSA_CLI:-build/release/clients/cli/dysa}"
if [[ ! -x "$cli" ]]; then
  [[ -z "${DYSA_CLI:-}" ]] || fail "DYSA_CLI=$cli is not an executable"
  echo "test-docker.sh: building the host's dysa"
  scripts/setup.sh
  [[ -f build/release/CMakeCache.txt ]] || cmake --preset release
  nice -n 19 cmake --build --preset release --target dysa -j"$(nproc)" || fail "building dysa failed"
fi
"$cli" status --help > /dev/null 2>&1 || fail "$cli has no 'status' verb"

# ---- 5. server in a container ------------------------------------------------------------------
# The first port from 50551 that nothing on this machine listens on (the container shares the
# host's network).
port_free() { ! (exec 3<> "/dev/tcp/127.0.0.1/$1") 2> /dev/null; }
port="${DYSA_TEST_PORT:-}"
if [[ -z "$port" ]]; then
  for ((port = 50551; port < 50651; port++)); do
    port_free "$port" && break
  done
fi
port_free "$port" || fail "port $port is in use"

log="$(mktemp /tmp/dysa-docker-test.XXXXXX.log)"
container=""
server_pid=""
server_status=""
# The dysa-server process below a process (buildah run -> buildah-oci-runtime -> dysa-server).
server_process() {
  local child
  for child in $(pgrep -P "$1" || true); do
    if [[ "$(cat "/proc/$child/comm" 2> /dev/null)" == dysa-server ]]; then
      echo "$child"
      return
    fi
    server_process "$child"
  done
}
# SIGTERM goes to dysa-server itself (it exits 0 then, and buildah run with its status): buildah
# run does not pass SIGTERM on but kills the container. buildah run gets SIGTERM only when no
# dysa-server is found, and SIGKILL after 10 s. `buildah rm` then removes the container.
stop_server() {
  if [[ -n "$server_pid" ]] && kill -0 "$server_pid" 2> /dev/null; then
    local target
    target="$(server_process "$server_pid" | head -n 1)"
    kill -TERM "${target:-$server_pid}" 2> /dev/null || true
    for _ in $(seq 1 100); do
      kill -0 "$server_pid" 2> /dev/null || break
      sleep 0.1
    done
    kill -KILL "$server_pid" 2> /dev/null || true
  fi
  if [[ -n "$server_pid" ]]; then
    server_status=0
    wait "$server_pid" || server_status=$?
    server_pid=""
  fi
}
cleanup() {
  stop_server
  if [[ -n "$container" ]]; then
    buildah rm "$container" > /dev/null 2>&1 || true
    container=""
  fi
  rm -f "$log"
}
trap cleanup EXIT

container=$(buildah from --pull=never "$image")
echo "test-docker.sh: starting dysa-server in $container on 0.0.0.0:$port"
buildah run --runtime runc --network host "$container" \
  dysa-server --listen "0.0.0.0:$port" --scene seed_basic --threads 1 2> "$log" &
server_pid=$!

# ---- 6. dysa status from the host -------------------------------------------------------------
answered=0
deadline=$((SECONDS + 60))
while ((SECONDS < deadline)); do
  if ! kill -0 "$server_pid" 2> /dev/null; then
    break
  fi
  if output=$("$cli" --server "127.0.0.1:$port" --timeout 2 status 2>&1); then
    answered=1
    break
  fi
  sleep 1
done

if [[ $answered -eq 1 ]]; then
  echo "$output"
fi
stop_server
echo "test-docker.sh: server log (tail):"
tail -n 10 "$log" | sed 's/^/  /'

if [[ $answered -ne 1 ]]; then
  [[ -n "${output:-}" ]] && echo "$output" | tail -n 5 >&2
  fail "dysa status did not reach the server in the container within 60 s"
fi
if [[ "$server_status" != 0 ]]; then
  fail "dysa-server exited with status $server_status on SIGTERM (expected 0)"
fi
echo "test-docker.sh: PASSED ($image, ${build_seconds}s build, $((size / 1000000)) MB)"
