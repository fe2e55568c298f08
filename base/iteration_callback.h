// Progress of a long offline computation and the caller's say in whether it
// goes on: Ceres' IterationCallback, for a whole estimate, screening,
// profile, diagnosis, design, campaign or report rather than one solve.
// The computation calls the callback after each unit of its work; kAbort
// makes it stop as soon as it can and return Interrupted(), writing
// nothing.
#ifndef KCRIG_BASE_ITERATION_CALLBACK_H_
#define KCRIG_BASE_ITERATION_CALLBACK_H_

#include <atomic>
#include <functional>
#include <mutex>
#include <string>
#include <utility>

#include "base/status.h"

namespace kcrig {

struct IterationSummary {
  // What is being done, one line for a progress display: "nominal fit",
  // "criterion surfaces 40/209", "estimation: iteration 3".
  std::string stage;
  // Fraction of the work done in [0, 1]; negative when not known.
  double fraction = -1;
  // Units of work done and in all (evaluations, iterations, fits); 0 when
  // not counted.
  int done = 0;
  int total = 0;
};

enum class CallbackReturn { kContinue, kAbort };

// Called one call at a time (a computation on several threads serializes
// its calls), never concurrently. An empty callback always continues.
using IterationCallback =
    std::function<CallbackReturn(const IterationSummary&)>;

// The error of a computation its callback stopped.
inline Status Interrupted(const std::string& what) {
  return Status::Error(what + ": interrupted");
}

// A computation's side of its callback: reports summaries one at a time
// from any thread and remembers an abort. A nested computation (an
// estimate in a campaign, the candidate fits of a diagnosis) gets a
// callback that reports the current summary again, so that it can be
// stopped while the display keeps showing the outer stage.
class ProgressReporter {
 public:
  explicit ProgressReporter(IterationCallback callback)
      : callback_(std::move(callback)) {}
  ProgressReporter(const ProgressReporter&) = delete;
  ProgressReporter& operator=(const ProgressReporter&) = delete;

  // Reports `summary`; false once the callback has asked to stop.
  bool Report(IterationSummary summary) {
    std::lock_guard<std::mutex> lock(mutex_);
    current_ = std::move(summary);
    return AskLocked();
  }

  bool aborted() const { return aborted_; }

  // For a nested computation: reports the current summary again (nothing
  // before the first Report). Valid while this reporter lives.
  IterationCallback Nested() {
    return [this](const IterationSummary&) {
      std::lock_guard<std::mutex> lock(mutex_);
      const bool go_on = reported_ ? AskLocked() : !aborted_;
      return go_on ? CallbackReturn::kContinue : CallbackReturn::kAbort;
    };
  }

 private:
  bool AskLocked() {
    reported_ = true;
    if (!aborted_ && callback_ &&
        callback_(current_) == CallbackReturn::kAbort) {
      aborted_ = true;
    }
    return !aborted_;
  }

  IterationCallback callback_;
  std::mutex mutex_;
  IterationSummary current_;
  bool reported_ = false;
  std::atomic<bool> aborted_{false};
};

}  // namespace kcrig

#endif  // KCRIG_BASE_ITERATION_CALLBACK_H_
