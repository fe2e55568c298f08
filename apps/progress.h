// A single progress line on stderr, rewritten in place, shown only when
// stderr is a terminal and the user did not ask for --quiet (logs and
// pipes stay clean).
#ifndef KCRIG_APPS_PROGRESS_H_
#define KCRIG_APPS_PROGRESS_H_

#include <string>

namespace kcrig {

class ProgressLine {
 public:
  explicit ProgressLine(bool quiet);
  ~ProgressLine();
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;

  void Show(const std::string& text);
  // Erases the line (before printing results).
  void Clear();

 private:
  bool enabled_;
  bool shown_ = false;
};

}  // namespace kcrig

#endif  // KCRIG_APPS_PROGRESS_H_
