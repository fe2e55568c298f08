#include "records/can_bus_log.h"

#include <chrono>

#include "records/internal/candump_log.h"

namespace kcrig {

CanBusLog::~CanBusLog() { Close(); }

void CanBusLog::Discard() {
  writer_.Stop();
  file_.Discard();
}

Status CanBusLog::Open(const std::string& path, const std::string& interface) {
  path_ = path;
  interface_ = interface;
  KCRIG_RETURN_IF_ERROR(file_.Open(path));
  writer_.Start(std::chrono::milliseconds(20), [this] { Drain(); });
  return Status::Ok();
}

// One write per wake-up: the frames of 20 ms, whole lines.
void CanBusLog::Drain() {
  TimedCanFrame frame;
  char line[kCandumpLineMax];
  lines_.clear();
  long count = 0;
  while (ring_.Pop(&frame)) {
    lines_.append(line, FormatCandumpLine(frame, interface_, line));
    ++count;
  }
  if (count == 0) return;
  if (file_.Write(lines_)) {
    written_.fetch_add(count, std::memory_order_relaxed);
  } else {
    write_failed_.store(true);
  }
}

std::string CanBusLog::WriteFailure() const {
  if (!write_failed_.load()) return "";
  return file_.partial_path() + ": " + file_.error() + "; its " +
         std::to_string(written_.load()) + " whole frames are kept";
}

Status CanBusLog::Close() {
  if (!file_.is_open()) return Status::Ok();
  writer_.Stop();
  return file_.Commit();
}

}  // namespace kcrig
