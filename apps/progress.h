// The command line's side of a long computation's IterationCallback: a
// single progress line on stderr, rewritten in place, shown only when
// stderr is a terminal and the user did not ask for --quiet (logs and
// pipes stay clean); and SIGINT/SIGTERM, which stop the computation.
#ifndef KCRIG_APPS_PROGRESS_H_
#define KCRIG_APPS_PROGRESS_H_

#include <atomic>
#include <chrono>
#include <functional>
#include <string>

#include "base/iteration_callback.h"

namespace kcrig {

class ProgressLine {
 public:
  explicit ProgressLine(bool quiet);
  ~ProgressLine();
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;

  void Show(const std::string& text);
  // With the `fraction` (0..1) of the work done: appends the time elapsed
  // and the time left at the average rate so far (an estimate, marked "~";
  // none before 2 % is done). Time counts from construction, or from the
  // start of a stage with its own fraction: the first of consecutive calls
  // with a fraction of 0.
  void Show(const std::string& text, double fraction);
  // Erases the line (before printing results). Text longer than the
  // terminal is cut: a wrapped line could not be rewritten in place.
  void Clear();

 private:
  bool enabled_;
  bool shown_ = false;
  double last_fraction_ = -1;
  std::chrono::steady_clock::time_point start_ =
      std::chrono::steady_clock::now();
};

// Installs handlers for SIGINT and SIGTERM that store the first signal's
// number in the returned flag: a rig session ramps down when it is
// non-zero, a long offline computation stops (StopSignal). A second signal
// only says that a third kills at once.
const std::atomic<int>& InstallStopSignalHandlers();

// The operator's stop from the console's page: the first signal's path
// (SIGINT's, when no signal came yet), so a run ramps down and a campaign
// stops exactly as on Ctrl-C.
void RequestOperatorStop();

// The emulated rig's emergency-stop button (RigEmulator::Button): SIGUSR1
// presses it (1), SIGUSR2 releases it (2); the handlers are installed on
// the first call.
std::atomic<int>& EmergencyStopButton();

// SIGINT and SIGTERM in a long offline command (estimate, screen,
// diagnose, design, campaign, report), through the HIL commands' handlers
// (InstallStopSignalHandlers): the signal makes the command's
// IterationCallback ask its computation to stop; the command then writes
// nothing, prints one line and exits with 128 + the signal (130 for
// SIGINT). A second signal acts as usual.
class StopSignal {
 public:
  StopSignal();  // installs the handlers

  // Passes each summary to `show` (a progress display; may be empty) and
  // asks to stop once a signal arrived.
  IterationCallback Callback(
      std::function<void(const IterationSummary&)> show = {}) const;
  bool received() const { return signal_->load() != 0; }
  // Prints "kcrig COMMAND: interrupted (SIGINT); OUTCOME" on stderr and
  // returns the exit status.
  int Exit(const std::string& command,
           const std::string& outcome = "nothing written") const;

 private:
  const std::atomic<int>* signal_;
};

}  // namespace kcrig

#endif  // KCRIG_APPS_PROGRESS_H_
