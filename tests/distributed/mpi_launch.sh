#!/bin/bash
# Runs a test program on N MPI ranks: mpi_launch.sh MPIEXEC N PROGRAM [ARGS...]. Exits 77
# (skipped, saying why) when mpirun cannot be found.
set -u
mpiexec=$1
ranks=$2
shift 2
# shellcheck source=mpi_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/mpi_common.sh"
mpi_require "$mpiexec"
exec "$mpiexec" --oversubscribe --allow-run-as-root -np "$ranks" "$@"
