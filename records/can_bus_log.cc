#include "records/can_bus_log.h"

#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>

#include "records/candump_log.h"

namespace kcrig {

CanBusLog::~CanBusLog() {
  if (file_ != nullptr) Close();
}

bool CanBusLog::Stop() {
  stop_.store(true, std::memory_order_release);
  if (writer_.joinable()) writer_.join();
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  return closed && !write_failed_;
}

void CanBusLog::Discard() {
  if (file_ == nullptr) return;
  Stop();
  std::remove((path_ + ".partial").c_str());
}

Status CanBusLog::Open(const std::string& path, const std::string& interface) {
  path_ = path;
  interface_ = interface;
  const std::string partial = path + ".partial";
  std::error_code ignored;  // fopen says what went wrong
  std::filesystem::create_directories(std::filesystem::path(path).parent_path(),
                                      ignored);
  file_ = std::fopen(partial.c_str(), "wb");
  if (file_ == nullptr) {
    return Status::Error(partial + ": cannot write (" + std::strerror(errno) +
                         ")");
  }
  stop_ = false;
  writer_ = std::thread([this] {
    while (!stop_.load(std::memory_order_acquire)) {
      Drain();
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    Drain();
  });
  return Status::Ok();
}

void CanBusLog::Drain() {
  TimedCanFrame frame;
  char line[kCandumpLineMax];
  bool any = false;
  while (ring_.Pop(&frame)) {
    const std::size_t n = FormatCandumpLine(frame, interface_, line);
    write_failed_ |= std::fwrite(line, 1, n, file_) != n;
    written_.fetch_add(1, std::memory_order_relaxed);
    any = true;
  }
  if (any) write_failed_ |= std::fflush(file_) != 0;
}

Status CanBusLog::Close() {
  if (file_ == nullptr) return Status::Ok();
  const bool written = Stop();
  const std::string partial = path_ + ".partial";
  if (!written) {
    return Status::Error(partial +
                         ": writing the CAN log failed (disk full?); the "
                         "frames written so far are in this file");
  }
  if (std::rename(partial.c_str(), path_.c_str()) != 0) {
    return Status::Error(path_ + ": cannot rename the CAN log into place (" +
                         std::strerror(errno) + ")");
  }
  return Status::Ok();
}

}  // namespace kcrig
