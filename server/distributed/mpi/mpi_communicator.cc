#include "mpi_communicator.h"

#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
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

// MPI counts and displacements are int, and the large-count calls of MPI 4 (MPI_Alltoallv_c ...)
// are missing from Debian 12's Open MPI 4.1. This fails loudly where a message still goes whole.
int CountOf(size_t bytes) {
  if (bytes > size_t(std::numeric_limits<int>::max())) {
    throw std::length_error("an MPI message of " + std::to_string(bytes) +
                            " bytes exceeds 2 GiB (int counts)");
  }
  return int(bytes);
}

// Polls a non-blocking collective to completion: spinning for a millisecond (as MPI's blocking
// calls do), then sleeping 100 us between polls. With `limit_s` > 0, a call still incomplete
// after that long means another rank hangs or died without mpirun noticing: this rank says so
// and ends the job, rather than wait forever.
void Wait(MPI_Request& request, const char* what, int rank, double limit_s) {
  const auto start = std::chrono::steady_clock::now();
  for (int done = 0;;) {
    Check(MPI_Test(&request, &done, MPI_STATUS_IGNORE), what);
    if (done) return;
    const double waited =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (limit_s > 0 && waited > limit_s) {
      std::fprintf(stderr,
                   "dysa: rank %d waited %.1f s in %s for the other ranks: one of them hangs or "
                   "has died; ending every rank (the limit is --rank-timeout %g s)\n",
                   rank, waited, what, limit_s);
      std::fflush(stderr);
      MPI_Abort(MPI_COMM_WORLD, 3);
      std::abort();
    }
    if (waited > 1e-3) std::this_thread::sleep_for(std::chrono::microseconds(100));
  }
}

// The rounds that move `bytes` at most `round` bytes at a time.
uint64_t RoundsFor(uint64_t bytes, uint64_t round) { return (bytes + round - 1) / round; }

// Bytes [r * round, (r + 1) * round) of a message of `size` bytes: how many there are.
size_t ChunkOf(size_t size, size_t round, uint64_t r) {
  const uint64_t begin = r * round;
  return begin >= size ? 0 : size_t(std::min<uint64_t>(round, size - begin));
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

MpiCommunicator::MpiCommunicator(const Options& options) : wait_limit_s_(options.wait_limit_s) {
  Check(MPI_Comm_rank(MPI_COMM_WORLD, &rank_), "MPI_Comm_rank");
  Check(MPI_Comm_size(MPI_COMM_WORLD, &size_), "MPI_Comm_size");
  if (options.round_bytes == 0) {
    throw std::invalid_argument("MpiCommunicator: round_bytes must be >= 1");
  }
  if (!(options.wait_limit_s > 0 && options.wait_limit_s <= 1e6)) {
    throw std::invalid_argument("--rank-timeout: must be in (0, 1e6] seconds");
  }
  // A round's buffer holds one chunk from (or for) every process, addressed by int offsets.
  round_ = std::min(options.round_bytes, size_t(std::numeric_limits<int>::max()) / size_t(size_));
}

uint64_t MpiCommunicator::MaxOverProcesses(uint64_t value) const {
  MPI_Request request;
  Check(MPI_Iallreduce(MPI_IN_PLACE, &value, 1, MPI_UINT64_T, MPI_MAX, MPI_COMM_WORLD, &request),
        "MPI_Iallreduce(MAX)");
  Wait(request, "MPI_Iallreduce(MAX)", rank_, wait_limit_s_);
  return value;
}

void MpiCommunicator::MaxInPlace(std::span<double> values) const {
  MPI_Request request;
  Check(MPI_Iallreduce(MPI_IN_PLACE, values.data(), CountOf(values.size()), MPI_DOUBLE, MPI_MAX,
                       MPI_COMM_WORLD, &request),
        "MPI_Iallreduce(MAX)");
  Wait(request, "MPI_Iallreduce(MAX)", rank_, wait_limit_s_);
}

void MpiCommunicator::SumInPlace(std::span<int64_t> values) const {
  MPI_Request request;
  Check(MPI_Iallreduce(MPI_IN_PLACE, values.data(), CountOf(values.size()), MPI_INT64_T, MPI_SUM,
                       MPI_COMM_WORLD, &request),
        "MPI_Iallreduce(SUM)");
  Wait(request, "MPI_Iallreduce(SUM)", rank_, wait_limit_s_);
}

std::vector<Bytes> MpiCommunicator::AllToAll(const std::vector<Bytes>& to) const {
  const size_t n = size_t(size_);
  if (to.size() != n) throw std::invalid_argument("AllToAll: one buffer per process");
  std::vector<uint64_t> send_sizes(n), receive_sizes(n);
  uint64_t longest = 0;
  for (size_t p = 0; p < n; ++p) send_sizes[p] = to[p].size();
  MPI_Request request;
  Check(MPI_Ialltoall(send_sizes.data(), 1, MPI_UINT64_T, receive_sizes.data(), 1, MPI_UINT64_T,
                      MPI_COMM_WORLD, &request),
        "MPI_Ialltoall");
  Wait(request, "MPI_Ialltoall", rank_, wait_limit_s_);
  std::vector<Bytes> from(n);
  for (size_t p = 0; p < n; ++p) {
    longest = std::max({longest, send_sizes[p], receive_sizes[p]});
    from[p].reserve(receive_sizes[p]);
  }
  // Every process takes part in as many rounds as the longest message anywhere needs; a round
  // moves each message's next chunk of at most round_ bytes.
  const uint64_t rounds = RoundsFor(MaxOverProcesses(longest), round_);
  std::vector<int> send_counts(n), send_offsets(n), receive_counts(n), receive_offsets(n);
  Bytes send, received;
  for (uint64_t r = 0; r < rounds; ++r) {
    send.clear();
    int receive_total = 0;
    for (size_t p = 0; p < n; ++p) {
      const size_t out = ChunkOf(to[p].size(), round_, r);
      send_counts[p] = int(out);
      send_offsets[p] = int(send.size());
      if (out) {
        const auto begin = to[p].begin() + std::ptrdiff_t(r * round_);
        send.insert(send.end(), begin, begin + std::ptrdiff_t(out));
      }
      receive_counts[p] = int(ChunkOf(size_t(receive_sizes[p]), round_, r));
      receive_offsets[p] = receive_total;
      receive_total += receive_counts[p];
    }
    received.resize(size_t(receive_total));
    Check(MPI_Ialltoallv(send.data(), send_counts.data(), send_offsets.data(), MPI_BYTE,
                         received.data(), receive_counts.data(), receive_offsets.data(), MPI_BYTE,
                         MPI_COMM_WORLD, &request),
          "MPI_Ialltoallv");
    Wait(request, "MPI_Ialltoallv", rank_, wait_limit_s_);
    for (size_t p = 0; p < n; ++p) {
      const auto begin = received.begin() + receive_offsets[p];
      from[p].insert(from[p].end(), begin, begin + receive_counts[p]);
    }
  }
  return from;
}

std::vector<Bytes> MpiCommunicator::GatherToRoot(std::span<const std::byte> mine) const {
  const size_t n = size_t(size_);
  const uint64_t size = mine.size();
  std::vector<uint64_t> sizes(n);
  MPI_Request request;
  Check(MPI_Igather(&size, 1, MPI_UINT64_T, sizes.data(), 1, MPI_UINT64_T, 0, MPI_COMM_WORLD,
                    &request),
        "MPI_Igather");
  Wait(request, "MPI_Igather", rank_, wait_limit_s_);
  std::vector<Bytes> from(rank_ == 0 ? n : 0);
  for (size_t p = 0; p < from.size(); ++p) from[p].reserve(sizes[p]);
  const uint64_t rounds = RoundsFor(MaxOverProcesses(size), round_);
  std::vector<int> counts(n), offsets(n);
  Bytes round;
  for (uint64_t r = 0; r < rounds; ++r) {
    const int count = int(ChunkOf(mine.size(), round_, r));
    int total = 0;
    if (rank_ == 0) {
      for (size_t p = 0; p < n; ++p) {
        counts[p] = int(ChunkOf(size_t(sizes[p]), round_, r));
        offsets[p] = total;
        total += counts[p];
      }
    }
    round.resize(size_t(total));
    Check(MPI_Igatherv(mine.data() + (count ? r * round_ : 0), count, MPI_BYTE, round.data(),
                       counts.data(), offsets.data(), MPI_BYTE, 0, MPI_COMM_WORLD, &request),
          "MPI_Igatherv");
    Wait(request, "MPI_Igatherv", rank_, wait_limit_s_);
    for (size_t p = 0; p < from.size(); ++p) {
      const auto begin = round.begin() + offsets[p];
      from[p].insert(from[p].end(), begin, begin + counts[p]);
    }
  }
  return from;
}

void MpiCommunicator::Broadcast(Bytes& bytes) const {
  uint64_t size = rank_ == 0 ? bytes.size() : 0;
  MPI_Request request;
  Check(MPI_Ibcast(&size, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD, &request), "MPI_Ibcast");
  // The other processes wait here for process 0's next command, without limit.
  Wait(request, "MPI_Ibcast", rank_, rank_ == 0 ? wait_limit_s_ : 0);
  if (rank_ != 0) bytes.resize(size);
  for (uint64_t r = 0; r < RoundsFor(size, round_); ++r) {
    const size_t count = ChunkOf(bytes.size(), round_, r);
    Check(MPI_Ibcast(bytes.data() + r * round_, int(count), MPI_BYTE, 0, MPI_COMM_WORLD, &request),
          "MPI_Ibcast");
    Wait(request, "MPI_Ibcast", rank_, wait_limit_s_);
  }
}

void MpiCommunicator::Abort(int code) const {
  MPI_Abort(MPI_COMM_WORLD, code);
  std::abort();
}

}  // namespace dysa::distributed
