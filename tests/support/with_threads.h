// Running a piece of a test with a given number of OpenMP threads.
#pragma once

#include <omp.h>

namespace dysa::testing {

// Runs `body` with OpenMP limited to `threads` and returns its result; the previous limit is
// restored afterwards, also when `body` throws.
template <class F>
auto WithThreads(int threads, F&& body) {
  struct Restore {
    int previous = omp_get_max_threads();
    ~Restore() { omp_set_num_threads(previous); }
  } restore;
  omp_set_num_threads(threads);
  return body();
}

}  // namespace dysa::testing
