#!/usr/bin/env bash
# Debian 12's Open MPI 4.1.4 for a GPU machine without it (no package registry there), so that
# the ranks' GPU tests (`ctest -L gpu`: mpi_gpu_ranks_*) run there instead of skipping.
#
#   scripts/openmpi-debs.sh fetch DIR            on a Debian 12 machine: apt-get download the
#                                                packages (about 7 MB) into DIR
#   eval "$(scripts/openmpi-debs.sh unpack DIR [PREFIX])"
#                                                on the GPU machine: unpack them into PREFIX
#                                                (default /tmp/deps, the prefix of the other
#                                                packages) and set the environment
#
# unpack adds the names Debian's alternatives would give (mpirun, mpiexec, mpicxx, mpicc) and
# prints the environment that relocates Open MPI to PREFIX (OPAL_PREFIX) and its PMIx plugins,
# lets it run as root, and, where there is no ssh, gives a local launch an agent that exists. CMake's FindMPI then
# finds it through PATH (docs/distributed.md, "GPU ranks").
set -euo pipefail
usage() {
  echo "usage: scripts/openmpi-debs.sh fetch DIR | unpack DIR [PREFIX]" >&2
  exit 2
}
[[ $# -ge 2 ]] || usage
mode=$1 dir=$2 prefix=${3:-/tmp/deps}
case "$mode" in
  fetch)
    mkdir -p "$dir"
    (cd "$dir" && apt-get download openmpi-bin openmpi-common libopenmpi-dev libopenmpi3 \
      libhwloc15 libpmix2 libevent-core-2.1-7 libevent-pthreads-2.1-7 libfabric1 libucx0 \
      libibverbs1 librdmacm1 libnl-3-200 libnl-route-3-200 libpsm2-2 libpsm-infinipath1 \
      libmunge2 libnuma1 libatomic1 2>&1 | grep -v '^W: Download is performed unsandboxed' || true)
    du -sh "$dir" >&2
    ;;
  unpack)
    ls "$dir"/*.deb > /dev/null 2>&1 || { echo "openmpi-debs.sh: no .deb files in '$dir'" >&2; exit 2; }
    mkdir -p "$prefix"
    for f in "$dir"/*.deb; do dpkg -x "$f" "$prefix"; done
    bin="$prefix/usr/bin"
    for n in mpirun mpiexec mpicxx mpicc mpic++; do ln -sf "$n.openmpi" "$bin/$n"; done
    lib="$prefix/usr/lib/x86_64-linux-gnu"
    echo "export OPAL_PREFIX=$prefix/usr OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1" \
      "LD_LIBRARY_PATH=$lib/openmpi/lib:$lib\${LD_LIBRARY_PATH:+:\$LD_LIBRARY_PATH} PATH=$bin:\$PATH"
    # PMIx loads its plugins from its build's path: where the machine has another PMIx there (the
    # H100 machine had one whose zlib plugin did not load), ours.
    echo "export PMIX_MCA_mca_base_component_path=$lib/pmix2/lib/pmix"
    command -v ssh > /dev/null || echo "export OMPI_MCA_plm_rsh_agent=false"
    ;;
  *) usage ;;
esac
