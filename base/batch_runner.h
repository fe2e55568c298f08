// Runs a batch of independent jobs whose results are bytes: on the threads
// of this process (LocalBatchRunner), or spread over the MPI ranks of a
// cluster job (cluster/ranks.h). Either way every caller receives every
// job's result in job order, so what follows the batch is the same on
// every rank and for any number of them.
#ifndef KCRIG_BASE_BATCH_RUNNER_H_
#define KCRIG_BASE_BATCH_RUNNER_H_

#include <functional>
#include <string>
#include <vector>

#include "base/parallel_for.h"

namespace kcrig {

class BatchRunner {
 public:
  virtual ~BatchRunner() = default;
  // work(j, &result) for j = 0 .. count-1, up to `threads` at a time in
  // this process; `results` receives every job's result. Collective: every
  // process of the job calls Run alike (the same count, in the same order).
  virtual void Run(int count, int threads,
                   const std::function<void(int, std::string*)>& work,
                   std::vector<std::string>* results) const = 0;
};

class LocalBatchRunner final : public BatchRunner {
 public:
  void Run(int count, int threads,
           const std::function<void(int, std::string*)>& work,
           std::vector<std::string>* results) const override {
    results->assign(count, std::string());
    ParallelFor(count, threads, [&](int j) { work(j, &(*results)[j]); });
  }
};

// The runner of `runner` when set, else this process's threads.
inline const BatchRunner& BatchesOr(const BatchRunner* runner) {
  static const LocalBatchRunner local;
  return runner != nullptr ? *runner : local;
}

}  // namespace kcrig

#endif  // KCRIG_BASE_BATCH_RUNNER_H_
