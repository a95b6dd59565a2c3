#include "mpi_test_main.h"

#include <gtest/gtest.h>

namespace dysa::distributed {
namespace {
const MpiCommunicator* g_comm = nullptr;
}  // namespace

const MpiCommunicator& TestComm() { return *g_comm; }

}  // namespace dysa::distributed

int main(int argc, char** argv) {
  dysa::distributed::MpiSession session(&argc, &argv);
  const dysa::distributed::MpiCommunicator comm;
  dysa::distributed::g_comm = &comm;
  ::testing::InitGoogleTest(&argc, argv);
  if (comm.rank() != 0) {
    delete ::testing::UnitTest::GetInstance()->listeners().Release(
        ::testing::UnitTest::GetInstance()->listeners().default_result_printer());
  }
  double failed = RUN_ALL_TESTS() != 0 ? 1 : 0;
  comm.MaxInPlace({&failed, 1});
  return failed > 0 ? 1 : 0;
}
