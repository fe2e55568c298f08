#include "hil/internal/run_logger.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <utility>

#include "rt_core/runtime/realtime.h"

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

RunLogger::~RunLogger() {
  Stop();
  ReleaseReserve();
}

Status RunLogger::Open() {
  if (options_.csv_path.empty()) return Status::Ok();
  KCRIG_RETURN_IF_ERROR(partial_.Open(options_.csv_path));
  const Status reserved = Reserve();
  if (!reserved.ok()) {
    partial_.Discard();
    return reserved;
  }
  pending_ = RunLogCsvHeader(log_);
  return Status::Ok();
}

Status RunLogger::Reserve() {
  const std::string path = options_.csv_path + ".reserve";
  const int fd =
      open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW | O_CLOEXEC,
           0600);
  if (fd < 0) {
    return Status::Error(path +
                         ": cannot create the reserve for the run's "
                         "record: " +
                         std::strerror(errno));
  }
  reserve_path_ = path;
  const int error = posix_fallocate(fd, 0, kRecordReserveBytes);
  close(fd);
  if (error != 0) {
    ReleaseReserve();
    return Status::Error(path + ": cannot reserve " +
                         std::to_string(kRecordReserveBytes >> 10) +
                         " KiB for the run's record (sidecar, timing.json): " +
                         std::strerror(error));
  }
  return Status::Ok();
}

void RunLogger::ReleaseReserve() {
  if (reserve_path_.empty()) return;
  unlink(reserve_path_.c_str());
  reserve_path_.clear();
}

void RunLogger::Start(SpscRing<CycleRecord>* ring) {
  last_progress_ = last_warning_ = std::chrono::steady_clock::now();
  worker_.Start(std::chrono::milliseconds(5),
                [this, ring, first = true]() mutable {
                  if (first) KeepOffCpu(options_.loop_cpu);
                  first = false;
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
    if (options_.on_record) options_.on_record(record);
    if (options_.csv_path.empty()) {
      next_cycle_ = record.cycle + 1;
      continue;
    }
    while (next_cycle_ < record.cycle && rows_ > 0) {
      LogSample filler = last_;
      filler.t = static_cast<double>(next_cycle_++) * options_.period;
      filler.fresh = false;
      Append(filler);
      ++filled_rows_;
      ++skipped_since_warning_;
    }
    Append(ToSample(record, options_.period));
    next_cycle_ = record.cycle + 1;
  }
}

void RunLogger::Append(const LogSample& sample) {
  last_ = sample;
  ++rows_;
  not_fresh_ += !sample.fresh;
  if (pending_.size() >= kMaxPendingBytes) {
    ++lost_rows_;
    return;
  }
  AppendRunLogCsvRow(log_, sample, &pending_);
  ++pending_rows_;
}

void RunLogger::Stream() {
  if (!partial_.is_open() || pending_.empty()) return;
  if (!partial_.Write(pending_)) {
    write_failed_.store(true, std::memory_order_relaxed);
    return;  // kept whole for the next try
  }
  written_rows_ += pending_rows_;
  pending_rows_ = 0;
  pending_.clear();
}

std::string RunLogger::WriteFailure() const {
  if (!write_failed_.load()) return "";
  return partial_.partial_path() + ": " + partial_.error() + "; its " +
         std::to_string(written_rows_) +
         " whole rows are kept (rename it to run.csv to read them), " +
         std::to_string(pending_rows_ + lost_rows_) + " rows not written";
}

void RunLogger::Stop() { worker_.Stop(); }

void RunLogger::Discard() {
  partial_.Discard();
  ReleaseReserve();
}

Status RunLogger::Finish(const std::string& log_dir) {
  ReleaseReserve();
  if (rows_ < 2) {
    Discard();
    return Status::Error(log_dir +
                         ": the run ended before two cycles were logged");
  }
  if (!write_failed_.load()) {
    return FinishStreamedRunLog(&partial_, log_, written_rows_);
  }
  // The whole rows that reached the disk stay in the partial file (closing
  // reports the failure already known); the sidecar says how many.
  partial_.Close();
  return WriteRunLogSidecar(partial_.path(), log_, written_rows_);
}

}  // namespace kcrig
