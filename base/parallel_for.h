// Runs independent jobs side by side: the candidate fits of a diagnosis,
// the grid points of a report's criterion surfaces.
#ifndef KCRIG_BASE_PARALLEL_FOR_H_
#define KCRIG_BASE_PARALLEL_FOR_H_

#include <algorithm>
#include <atomic>
#include <functional>
#include <thread>
#include <vector>

namespace kcrig {

// Threads a computation uses in a process of its own unless told otherwise:
// the two cores of the rig PC and CI machines the benchmarks are measured
// on (cluster's ThreadsPerRank gives a rank under mpirun one).
inline constexpr int kDefaultThreads = 2;

// Runs fn(0 .. count-1) on up to `threads` threads (the caller's included),
// each taking the next job when it finishes one.
inline void ParallelFor(int count, int threads,
                        const std::function<void(int)>& fn) {
  std::atomic<int> next{0};
  auto work = [&] {
    for (int i = next++; i < count; i = next++) fn(i);
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < std::min(threads, count); ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
}

}  // namespace kcrig

#endif  // KCRIG_BASE_PARALLEL_FOR_H_
