// A few threads that run the iterations of a loop and sleep between loops: the frame decoder's
// parallelism. A client decodes next to the server it watches (the same box, in the common
// setup), and OpenMP's threads would spin between its parallel regions, taking cores from the
// server's solver threads at their barriers: a `dysa watch` decoding every frame beside
// `dysa-server --threads 15` on 16 cores halved the server's frame rate (21.9 against 43.9
// frames/s; bench/client_interference.sh). These threads block on a condition variable instead,
// so between frames a client costs the server nothing.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace dysa::codec {

class TaskPool {
 public:
  // `workers` threads besides the caller's (0: loops run on the caller alone).
  explicit TaskPool(int workers);
  ~TaskPool();
  TaskPool(const TaskPool&) = delete;
  TaskPool& operator=(const TaskPool&) = delete;

  // Calls body(i) for every i in [0, n), on the workers and the calling thread, and returns
  // when all are done; the first exception a call threw is rethrown here. One Run at a time.
  void Run(size_t n, const std::function<void(size_t)>& body);

  int workers() const { return int(threads_.size()); }

 private:
  void Work();
  // Takes iterations of the current loop until none are left.
  void Drain();

  std::mutex mu_;
  std::condition_variable wake_;  // a loop started, or the pool stops
  std::condition_variable done_;  // the loop's last iteration finished
  const std::function<void(size_t)>* body_ = nullptr;
  size_t size_ = 0;
  size_t next_ = 0;      // the next iteration to hand out
  size_t finished_ = 0;  // iterations done
  uint64_t generation_ = 0;
  std::exception_ptr error_;
  bool stop_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace dysa::codec
