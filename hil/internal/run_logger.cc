#include "hil/internal/run_logger.h"

#include <algorithm>
#include <chrono>
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

RunLogger::RunLogger(Options options) : options_(std::move(options)) {
  log_.has_measured_force = true;
  log_.has_commanded_force = true;
  log_.has_loop_columns = true;
}

RunLogger::~RunLogger() { Stop(); }

Status RunLogger::Open() {
  if (options_.csv_path.empty()) return Status::Ok();
  log_.samples.reserve(
      static_cast<size_t>(std::min(options_.expected_duration, 600.0) /
                          options_.period) +
      16);
  KCRIG_RETURN_IF_ERROR(partial_.Open(options_.csv_path));
  partial_.Write(RunLogCsvHeader(log_));
  return Status::Ok();
}

void RunLogger::Start(SpscRing<CycleRecord>* ring) {
  last_progress_ = last_warning_ = std::chrono::steady_clock::now();
  worker_.Start(std::chrono::milliseconds(5), [this, ring] {
    Drain(ring);
    Stream();
    Report();
  });
}

void RunLogger::Report() {
  const auto now = std::chrono::steady_clock::now();
  if (options_.on_warning && skipped_since_warning_ > 0 &&
      now - last_warning_ >= std::chrono::seconds(1)) {
    options_.on_warning(
        "overrun: " + std::to_string(skipped_since_warning_) +
        " cycle(s) skipped since the last warning (see timing.json)");
    skipped_since_warning_ = 0;
    last_warning_ = now;
  }
  if (options_.on_progress &&
      now - last_progress_ > std::chrono::milliseconds(250)) {
    last_progress_ = now;
    options_.on_progress(static_cast<double>(next_cycle_) * options_.period);
  }
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
  if (!partial_.is_open() || streamed_ >= log_.samples.size()) return;
  for (; streamed_ < log_.samples.size(); ++streamed_) {
    AppendRunLogCsvRow(log_, log_.samples[streamed_], &rows_);
  }
  partial_.Write(rows_);
  partial_.Flush();
  rows_.clear();
}

void RunLogger::Stop() { worker_.Stop(); }

void RunLogger::Discard() { partial_.Discard(); }

Status RunLogger::Finish(const std::string& log_dir) {
  if (log_.samples.size() < 2) {
    Discard();
    return Status::Error(log_dir +
                         ": the run ended before two cycles were logged");
  }
  return FinishStreamedRunLog(&partial_, log_);
}

}  // namespace kcrig
