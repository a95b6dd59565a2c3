# Sourced by the mpi tests' scripts (bash): what each needs around its mpirun.

# mpi_require MPIEXEC: exits 77 (ctest's skip), saying why, when mpirun cannot be found; then
# sets the environment the ranks run in.
mpi_require() {
  if ! command -v "$1" > /dev/null 2>&1; then
    echo "SKIP: no mpirun ('$1' not found): install openmpi-bin (scripts/setup.sh)"
    exit 77
  fi
  # Waiting OpenMP threads sleep rather than spin: the ranks share CI's 2 cores.
  export OMP_WAIT_POLICY=PASSIVE
  # No X display: Open MPI's hwloc probes any display it is given for GPUs (its gl component),
  # and the viewer tests' Xvfb servers come and go beside these tests: one that closed in the
  # middle of that probe killed mpirun ("X connection to :0 broken") in a full ctest run.
  unset DISPLAY
  export HWLOC_COMPONENTS="${HWLOC_COMPONENTS:+$HWLOC_COMPONENTS,}-gl"
  # In an ASan build, LeakSanitizer would report Open MPI's own allocations left at exit; our
  # code's leaks are checked by the in-process tests (distributed_simulation_test).
  export ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0"
}

# field NAME TEXT: the value of the line "NAME: VALUE ..." of `dysa run`'s output TEXT (up to
# the first space or ';').
field() { sed -n "s/^$1: \([^ ;]*\).*/\1/p" <<< "$2"; }

# mpi_expect_the_job_ends JOB RANK_PID...: after a rank was killed (or stopped), mpirun (JOB, a
# child of this shell) must exit non-zero within 30 s and no rank outlive it by 10 s (mpirun's
# teardown of the other ranks may finish just after it exits); otherwise calls the script's
# `fail`.
mpi_expect_the_job_ends() {
  local job=$1 pid status start=$SECONDS
  shift
  for _ in $(seq 150); do
    kill -0 "$job" 2> /dev/null || break
    sleep 0.2
  done
  kill -0 "$job" 2> /dev/null && fail "mpirun still runs 30 s after a rank was killed or stopped"
  wait "$job"
  status=$?
  echo "mpirun exited with status $status after $((SECONDS - start)) s"
  [ $status -ne 0 ] || fail "mpirun exited 0 after a rank was killed or stopped"
  for pid in "$@"; do
    for _ in $(seq 50); do
      kill -0 "$pid" 2> /dev/null || break
      sleep 0.2
    done
    kill -0 "$pid" 2> /dev/null && fail "rank pid $pid still runs 10 s after mpirun exited"
  done
  return 0
}
