#include "hil/run_logger.h"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <utility>

namespace kcrig {
namespace {

LogSample ToSample(const CycleRecord& r, double period) {
  LogSample s;
  s.t = static_cast<double>(r.cycle) * period;
  s.force << r.force[0], r.force[1], r.force[2];
  s.y << r.y[0], r.y[1], r.y[2], r.y[3], r.y[4], r.y[5];
  s.commanded << r.commanded[0], r.commanded[1], r.commanded[2];
  s.fresh = r.fresh;
  s.phase = RunPhaseName(r.phase);
  s.safety = static_cast<int>(r.safety);
  s.rig_sample = r.rig_sample;
  s.rig_status = r.rig_status;
  s.predicted << r.predicted[0], r.predicted[1], r.predicted[2], r.predicted[3],
      r.predicted[4], r.predicted[5];
  return s;
}

}  // namespace

RunLogger::RunLogger(Options options)
    : options_(std::move(options)),
      partial_path_(options_.csv_path + ".partial") {
  log_.has_measured_force = true;
  log_.has_commanded_force = true;
  log_.has_loop_columns = true;
}

RunLogger::~RunLogger() {
  Stop();
  if (partial_ != nullptr) std::fclose(partial_);
}

Status RunLogger::Open() {
  if (options_.csv_path.empty()) return Status::Ok();
  log_.samples.reserve(
      static_cast<size_t>(std::min(options_.expected_duration, 600.0) /
                          options_.period) +
      16);
  partial_ = std::fopen(partial_path_.c_str(), "wb");
  if (partial_ == nullptr) {
    return Status::Error(partial_path_ + ": cannot write (" +
                         std::strerror(errno) + ")");
  }
  const std::string header = RunLogCsvHeader(log_);
  std::fwrite(header.data(), 1, header.size(), partial_);
  return Status::Ok();
}

void RunLogger::Start(SpscRing<CycleRecord>* ring) {
  thread_ = std::thread([this, ring] {
    auto last_progress = std::chrono::steady_clock::now();
    auto last_warning = last_progress;
    for (;;) {
      const bool done = loop_done_.load(std::memory_order_acquire);
      Drain(ring);
      Stream();
      if (done) break;
      const auto now = std::chrono::steady_clock::now();
      if (options_.on_warning && skipped_since_warning_ > 0 &&
          now - last_warning >= std::chrono::seconds(1)) {
        options_.on_warning(
            "overrun: " + std::to_string(skipped_since_warning_) +
            " cycle(s) skipped since the last warning (see timing.json)");
        skipped_since_warning_ = 0;
        last_warning = now;
      }
      if (options_.on_progress &&
          now - last_progress > std::chrono::milliseconds(250)) {
        last_progress = now;
        options_.on_progress(static_cast<double>(next_cycle_) *
                             options_.period);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  });
}

void RunLogger::Drain(SpscRing<CycleRecord>* ring) {
  CycleRecord record;
  while (ring->Pop(&record)) {
    if (options_.csv_path.empty()) {
      next_cycle_ = record.cycle + 1;
      continue;
    }
    while (next_cycle_ < record.cycle && !log_.samples.empty()) {
      LogSample filler = log_.samples.back();
      filler.t = static_cast<double>(next_cycle_++) * options_.period;
      filler.fresh = false;
      log_.samples.push_back(filler);
      ++filled_rows_;
      ++skipped_since_warning_;
    }
    log_.samples.push_back(ToSample(record, options_.period));
    next_cycle_ = record.cycle + 1;
  }
}

void RunLogger::Stream() {
  if (partial_ == nullptr || streamed_ >= log_.samples.size()) return;
  for (; streamed_ < log_.samples.size(); ++streamed_) {
    AppendRunLogCsvRow(log_, log_.samples[streamed_], &rows_);
  }
  stream_failed_ |=
      std::fwrite(rows_.data(), 1, rows_.size(), partial_) != rows_.size() ||
      std::fflush(partial_) != 0;
  rows_.clear();
}

void RunLogger::Stop() {
  if (!thread_.joinable()) return;
  loop_done_.store(true, std::memory_order_release);
  thread_.join();
}

void RunLogger::Discard() {
  if (partial_ == nullptr) return;
  std::fclose(partial_);
  partial_ = nullptr;
  std::remove(partial_path_.c_str());
}

Status RunLogger::Finish(const std::string& log_dir) {
  if (log_.samples.size() < 2) {
    Discard();
    return Status::Error(log_dir +
                         ": the run ended before two cycles were logged");
  }
  const bool closed = std::fclose(partial_) == 0;
  partial_ = nullptr;
  if (!closed || stream_failed_) {
    return Status::Error(partial_path_ +
                         ": writing the log failed (disk "
                         "full?); the rows written so far are "
                         "in this file");
  }
  return FinishStreamedRunLog(partial_path_, options_.csv_path, log_);
}

}  // namespace kcrig
