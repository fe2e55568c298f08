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

void CanBusLog::Drain() {
  TimedCanFrame frame;
  char line[kCandumpLineMax];
  bool any = false;
  while (ring_.Pop(&frame)) {
    file_.Write({line, FormatCandumpLine(frame, interface_, line)});
    written_.fetch_add(1, std::memory_order_relaxed);
    any = true;
  }
  if (any) file_.Flush();
}

Status CanBusLog::Close() {
  if (!file_.is_open()) return Status::Ok();
  writer_.Stop();
  return file_.Commit();
}

}  // namespace kcrig
