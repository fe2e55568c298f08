// A single progress line on stderr, rewritten in place, shown only when
// stderr is a terminal and the user did not ask for --quiet (logs and
// pipes stay clean).
#ifndef KCRIG_APPS_PROGRESS_H_
#define KCRIG_APPS_PROGRESS_H_

#include <chrono>
#include <string>

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
  // last call with a fraction of 0 (the start of a stage with its own
  // fraction).
  void Show(const std::string& text, double fraction);
  // Erases the line (before printing results). Text longer than the
  // terminal is cut: a wrapped line could not be rewritten in place.
  void Clear();

 private:
  bool enabled_;
  bool shown_ = false;
  std::chrono::steady_clock::time_point start_ =
      std::chrono::steady_clock::now();
};

}  // namespace kcrig

#endif  // KCRIG_APPS_PROGRESS_H_
