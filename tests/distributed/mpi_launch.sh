#!/bin/bash
# Runs a test program on N MPI ranks: mpi_launch.sh MPIEXEC N PROGRAM [ARGS...]. Exits 77
# (skipped, saying why) when mpirun cannot be found.
set -u
mpiexec=$1
ranks=$2
shift 2
if ! command -v "$mpiexec" > /dev/null 2>&1; then
  echo "SKIP: no mpirun ('$mpiexec' not found): install openmpi-bin (scripts/setup.sh)"
  exit 77
fi
# In an ASan build, LeakSanitizer would report Open MPI's own allocations left at exit.
export ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0"
exec "$mpiexec" --oversubscribe --allow-run-as-root -np "$ranks" "$@"
