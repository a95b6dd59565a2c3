// The MPI main of the GoogleTest programs that ctest runs under mpirun (mpi_test_main.cc): every
// rank runs every test (their collectives pair up); only rank 0 prints, and the job fails when
// any rank's tests failed.
#pragma once

#include "mpi_communicator.h"

namespace dysa::distributed {

// MPI_COMM_WORLD with the default options, for the tests; valid while main runs them.
const MpiCommunicator& TestComm();

}  // namespace dysa::distributed
