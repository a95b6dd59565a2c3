#include "mpi_communicator.h"

#include <mpi.h>

#include <chrono>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>

namespace dysa::distributed {
namespace {

void Check(int code, const char* what) {
  if (code == MPI_SUCCESS) return;
  char text[MPI_MAX_ERROR_STRING];
  int length = 0;
  MPI_Error_string(code, text, &length);
  throw std::runtime_error(std::string(what) + ": " + std::string(text, size_t(length)));
}

// MPI counts and displacements are int: a message past 2 GiB needs the large-count API of
// MPI 4, which Debian 12's Open MPI 4.1 lacks.
int CountOf(size_t bytes) {
  if (bytes > size_t(std::numeric_limits<int>::max())) {
    throw std::length_error("an MPI message of " + std::to_string(bytes) +
                            " bytes exceeds 2 GiB (int counts)");
  }
  return int(bytes);
}

}  // namespace

MpiSession::MpiSession(int* argc, char*** argv, bool any_thread) {
  // Only the main thread calls MPI (OpenMP threads never do), or one thread at a time.
  const int wanted = any_thread ? MPI_THREAD_SERIALIZED : MPI_THREAD_FUNNELED;
  int provided = 0;
  Check(MPI_Init_thread(argc, argv, wanted, &provided), "MPI_Init_thread");
  if (provided < wanted) {
    MPI_Finalize();
    throw std::runtime_error(
        "this MPI library does not let threads other than the main one call "
        "it (MPI_THREAD_SERIALIZED)");
  }
}

MpiSession::~MpiSession() { MPI_Finalize(); }

bool LaunchedByMpirun() {
  return std::getenv("OMPI_COMM_WORLD_SIZE") != nullptr || std::getenv("PMIX_RANK") != nullptr ||
         std::getenv("PMI_RANK") != nullptr;
}

MpiCommunicator::MpiCommunicator() {
  Check(MPI_Comm_rank(MPI_COMM_WORLD, &rank_), "MPI_Comm_rank");
  Check(MPI_Comm_size(MPI_COMM_WORLD, &size_), "MPI_Comm_size");
}

void MpiCommunicator::MaxInPlace(std::span<double> values) const {
  Check(MPI_Allreduce(MPI_IN_PLACE, values.data(), CountOf(values.size()), MPI_DOUBLE, MPI_MAX,
                      MPI_COMM_WORLD),
        "MPI_Allreduce(MAX)");
}

void MpiCommunicator::SumInPlace(std::span<int64_t> values) const {
  Check(MPI_Allreduce(MPI_IN_PLACE, values.data(), CountOf(values.size()), MPI_INT64_T, MPI_SUM,
                      MPI_COMM_WORLD),
        "MPI_Allreduce(SUM)");
}

std::vector<Bytes> MpiCommunicator::AllToAll(const std::vector<Bytes>& to) const {
  const size_t n = size_t(size_);
  if (to.size() != n) throw std::invalid_argument("AllToAll: one buffer per process");
  std::vector<int> send_counts(n), send_offsets(n), recv_counts(n), recv_offsets(n);
  Bytes send;
  for (size_t p = 0; p < n; ++p) {
    send_counts[p] = CountOf(to[p].size());
    send_offsets[p] = CountOf(send.size());
    send.insert(send.end(), to[p].begin(), to[p].end());
  }
  Check(
      MPI_Alltoall(send_counts.data(), 1, MPI_INT, recv_counts.data(), 1, MPI_INT, MPI_COMM_WORLD),
      "MPI_Alltoall");
  size_t total = 0;
  for (size_t p = 0; p < n; ++p) {
    recv_offsets[p] = CountOf(total);
    total += size_t(recv_counts[p]);
  }
  Bytes received(total);
  Check(
      MPI_Alltoallv(send.data(), send_counts.data(), send_offsets.data(), MPI_BYTE, received.data(),
                    recv_counts.data(), recv_offsets.data(), MPI_BYTE, MPI_COMM_WORLD),
      "MPI_Alltoallv");
  std::vector<Bytes> from(n);
  for (size_t p = 0; p < n; ++p) {
    const auto begin = received.begin() + recv_offsets[p];
    from[p].assign(begin, begin + recv_counts[p]);
  }
  return from;
}

std::vector<Bytes> MpiCommunicator::GatherToRoot(std::span<const std::byte> mine) const {
  const size_t n = size_t(size_);
  int count = CountOf(mine.size());
  std::vector<int> counts(n), offsets(n);
  Check(MPI_Gather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, MPI_COMM_WORLD), "MPI_Gather");
  size_t total = 0;
  for (size_t p = 0; p < n; ++p) {
    offsets[p] = CountOf(total);
    total += size_t(counts[p]);
  }
  Bytes all(rank_ == 0 ? total : 0);
  Check(MPI_Gatherv(mine.data(), count, MPI_BYTE, all.data(), counts.data(), offsets.data(),
                    MPI_BYTE, 0, MPI_COMM_WORLD),
        "MPI_Gatherv");
  std::vector<Bytes> from;
  if (rank_ != 0) return from;
  from.resize(n);
  for (size_t p = 0; p < n; ++p) {
    const auto begin = all.begin() + offsets[p];
    from[p].assign(begin, begin + counts[p]);
  }
  return from;
}

void MpiCommunicator::Broadcast(Bytes& bytes) const {
  uint64_t size = rank_ == 0 ? bytes.size() : 0;
  MPI_Request request;
  Check(MPI_Ibcast(&size, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD, &request), "MPI_Ibcast");
  const auto start = std::chrono::steady_clock::now();
  for (int done = 0;;) {
    Check(MPI_Test(&request, &done, MPI_STATUS_IGNORE), "MPI_Test");
    if (done) break;
    if (std::chrono::steady_clock::now() - start > std::chrono::milliseconds(1)) {
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  }
  if (rank_ != 0) bytes.resize(size);
  Check(MPI_Bcast(bytes.data(), CountOf(bytes.size()), MPI_BYTE, 0, MPI_COMM_WORLD), "MPI_Bcast");
}

void MpiCommunicator::Abort(int code) const {
  MPI_Abort(MPI_COMM_WORLD, code);
  std::abort();
}

}  // namespace dysa::distributed
