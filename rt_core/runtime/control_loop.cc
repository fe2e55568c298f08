#include "rt_core/runtime/control_loop.h"

#include <algorithm>
#include <cmath>
#include <thread>

#include "rt_core/model/semi_implicit_euler.h"

namespace kcrig {

ControlLoop::ControlLoop(const SuspensionParameters<double>& model,
                         const LoopOptions& options, RigInterface* rig,
                         SpscRing<CycleRecord>* ring,
                         const std::atomic<int>* stop_signal)
    : model_(model),
      options_(options),
      rig_(rig),
      ring_(ring),
      stop_signal_(stop_signal),
      virtual_time_(!IsRealTime(options.clock)),
      profile_(options.profile, options.excitation),
      safety_(options.safety, options.period) {
  direction_ << std::cos(options.excitation.phi),
      std::sin(options.excitation.phi), 0.0;
  const double duration =
      options.max_duration > 0 ? options.max_duration : profile_.duration();
  end_cycle_ = std::llround(duration / options.period);
}

LoopResult ControlLoop::Run() {
  CycleTimer timer(std::llround(options_.period * 1e9), end_cycle_ - 1,
                   options_.clock);
  timer.Start();
  for (;;) {
    const CycleTimer::Wake wake = timer.WaitForNextCycle();
    const std::int64_t cycle_start = MonotonicNanoseconds();
    timing_.wakeup.Record(wake.wakeup_latency);
    wakeup_latency_ = wake.wakeup_latency;
    overruns_so_far_ = timer.overruns();
    const bool go_on = Cycle(wake.cycle, wake.skipped);
    timing_.cycle.Record(MonotonicNanoseconds() - cycle_start);
    if (!go_on) break;
  }
  result_.overruns = timer.overruns();
  result_.skipped_cycles = timer.skipped_cycles();
  result_.skipped_by_late_wakeup = timer.skipped_by_late_wakeup();
  result_.dropped_records = ring_ ? ring_->dropped() : 0;
  return result_;
}

bool ControlLoop::Valid(const RigMeasurement& m) const {
  return m.force.allFinite() && m.y.allFinite();
}

// The rig takes one sample per request, so a step of the counter can miss
// at most one sample per cycle since the last fresh one; a larger step, or
// one backwards, is no loss but a discontinuity (a restarted rig, a counter
// read in the wrong word order, a garbled reply).
void ControlLoop::CountSampleGap(std::uint32_t step, std::int64_t cycles) {
  if (step >= 1 && step - 1 <= static_cast<std::uint64_t>(cycles)) {
    result_.lost_rig_samples += step - 1;
  } else {
    ++result_.rig_sample_jumps;
  }
}

bool ControlLoop::Cycle(std::int64_t cycle, std::int64_t skipped) {
  ++result_.cycles;
  const std::int64_t t0 = MonotonicNanoseconds();
  bool fresh = false;
  if (rig_ != nullptr) {
    const std::uint32_t previous = measurement_.sample;
    const IoResult read = rig_->Read(&measurement_);
    fresh = read == IoResult::kFresh;
    if (read == IoResult::kStale) ++result_.stale;
    if (read == IoResult::kError) ++result_.read_errors;
    if (read == IoResult::kFault) {
      ++result_.read_errors;
      transport_fault_ = true;
    }
    if (read == IoResult::kForeign) foreign_master_ = true;
    if (fresh && !Valid(measurement_)) {
      // Never let a NaN reach the model or the log: keep the last good
      // sample and trip (in CheckEvents).
      measurement_ = last_good_;
      invalid_sample_ = true;
      fresh = false;
    }
    if (fresh) {
      ++result_.fresh;
      if (have_sample_) {
        CountSampleGap(measurement_.sample - previous,
                       cycle - last_fresh_cycle_);
      }
      have_sample_ = true;
      last_fresh_cycle_ = cycle;
      last_good_ = measurement_;
    }
  }
  const std::int64_t t1 = MonotonicNanoseconds();
  timing_.read.Record(t1 - t0);

  CycleRecord record;
  Compute(cycle, skipped, fresh, &record);
  const std::int64_t t2 = MonotonicNanoseconds();
  timing_.compute.Record(t2 - t1);

  if (rig_ != nullptr && withhold_commands_) {
    ++result_.withheld_after_trip;
  } else if (rig_ != nullptr) {
    const bool delivered = rig_->Write(command_) != IoResult::kError;
    result_.write_errors += !delivered;
    if (safety_.state() != SafetyState::kNormal) {
      ++result_.commands_after_trip;
      result_.undelivered_after_trip += !delivered;
    }
  }
  timing_.write.Record(MonotonicNanoseconds() - t2);
  if (ring_ != nullptr) {
    // On a virtual clock no deadline waits: the loop waits for the logger
    // rather than drop a row of the log.
    while (virtual_time_ && ring_->full()) std::this_thread::yield();
    ring_->Push(record);
  }

  const bool disabled = safety_.state() == SafetyState::kDisabled;
  const bool finished =
      safety_.state() == SafetyState::kNormal && cycle + 1 >= end_cycle_;
  return !(disabled || finished);
}

void ControlLoop::Compute(std::int64_t cycle, std::int64_t skipped, bool fresh,
                          CycleRecord* record) {
  const double t = cycle * options_.period;
  const RunPhase phase = profile_.Phase(t);
  if (rig_ != nullptr && fresh) CheckMeasurement(cycle, phase);
  CheckEvents(cycle, skipped, fresh);
  const Vec3<double> command = Command(cycle, t, phase);
  // Logged with the measurement it was checked against (time t).
  for (int k = 0; k < 6; ++k) record->predicted[k] = state_.y(k);
  Predict(fresh, command, skipped);
  Record(cycle, fresh, phase, command, record);
  if (tare_count_ > 0) result_.rest_pose = tare_sum_ / tare_count_;
}

void ControlLoop::CheckMeasurement(std::int64_t cycle, RunPhase phase) {
  safety_.FreshSample();
  if (phase == RunPhase::kTare) {
    tare_sum_ += measurement_.y;
    ++tare_count_;
  }
  const Vec6<double> rest =
      tare_count_ > 0 ? Vec6<double>(tare_sum_ / tare_count_) : measurement_.y;
  // Travel and angle limits on the absolute pose; the error detector on
  // the pose relative to the rest pose (the sensors' zero is the rig's),
  // once the rest pose is known.
  int channel = -1;
  TripCause cause = safety_.CheckMeasurement(
      measurement_.y, rest, state_.y, phase != RunPhase::kTare, &channel);
  // The rig faulted, or stopped being enabled (local mode, e-stop).
  if ((measurement_.status & kRigFault) ||
      !(measurement_.status & kRigEnabled)) {
    cause = TripCause::kRigFault;
  }
  int axis = -1;
  if (cause == TripCause::kNone &&
      safety_.ForceOffCommand(measurement_.force, &axis)) {
    cause = TripCause::kForceTracking;
    channel = axis;
  }
  if (cause != TripCause::kNone && safety_.state() == SafetyState::kNormal) {
    result_.trip_channel = channel;
    result_.rig_fault_code = measurement_.fault_code;
    safety_.Trip(cause, cycle);
  }
}

void ControlLoop::CheckEvents(std::int64_t cycle, std::int64_t skipped,
                              bool fresh) {
  if (rig_ != nullptr) {
    if (!fresh && safety_.MissedSamples(static_cast<int>(
                      std::min<std::int64_t>(skipped + 1, 1 << 20)))) {
      safety_.Trip(TripCause::kWatchdog, cycle);
    }
    if (invalid_sample_) {
      invalid_sample_ = false;
      safety_.Trip(TripCause::kInvalidMeasurement, cycle);
    }
    if (transport_fault_) {
      transport_fault_ = false;
      safety_.Trip(TripCause::kTransportFault, cycle);
    }
    if (foreign_master_) {
      foreign_master_ = false;
      withhold_commands_ = true;
      safety_.Trip(TripCause::kForeignMaster, cycle);
    }
  }
  for (int i = 0; i < log_failures_; ++i) {
    if (safety_.state() == SafetyState::kNormal &&
        log_failed_[i]->load(std::memory_order_relaxed)) {
      safety_.Trip(TripCause::kLogWrite, cycle);
    }
  }
  if (stop_signal_ != nullptr) {
    const int signal = stop_signal_->load(std::memory_order_relaxed);
    if (signal != 0 && safety_.state() == SafetyState::kNormal) {
      result_.signal = signal;
      safety_.Trip(TripCause::kSignal, cycle);
    }
  }
  if (safety_.state() != SafetyState::kNormal &&
      result_.cause == TripCause::kNone) {
    result_.cause = safety_.cause();
    result_.trip_cycle = safety_.trip_cycle();
  }
}

Vec3<double> ControlLoop::Command(std::int64_t cycle, double t,
                                  RunPhase phase) {
  // Excitation through the safety limits.
  const Vec3<double> wanted = options_.excitation.fmax *
                              profile_.Level(t + options_.period) * direction_;
  const Vec3<double> command = safety_.Limit(wanted, cycle);
  result_.limited_commands = safety_.limited_commands();
  command_.force = command;
  command_.z_a = options_.excitation.z_a;
  command_.enable = safety_.state() != SafetyState::kDisabled;
  command_.sequence = static_cast<std::uint16_t>(cycle);
  command_.phase = static_cast<std::uint8_t>(1 + static_cast<int>(phase));
  command_.safety = static_cast<std::uint8_t>(safety_.state());
  return command;
}

void ControlLoop::Predict(bool fresh, const Vec3<double>& command,
                          std::int64_t skipped) {
  // The model under the measured force (the command when no sample
  // arrived), over the cycles skipped too (bounded).
  RigLoad<double> load;
  load.force = fresh ? measurement_.force : command;
  load.point << 0.0, 0.0, options_.excitation.z_a;
  const std::int64_t steps = 1 + std::min<std::int64_t>(skipped, 50);
  for (std::int64_t s = 0; s < steps; ++s) {
    SemiImplicitEulerStep(model_, load, options_.period, &state_);
  }
}

void ControlLoop::Record(std::int64_t cycle, bool fresh, RunPhase phase,
                         const Vec3<double>& command,
                         CycleRecord* record) const {
  record->cycle = cycle;
  record->rig_sample = measurement_.sample;
  record->rig_status = measurement_.status;
  record->rig_fault = measurement_.fault_code;
  record->fresh = fresh;
  record->phase = phase;
  record->safety = safety_.state();
  record->cause = safety_.cause();
  record->trip_channel = static_cast<std::int8_t>(
      record->cause == TripCause::kNone ? -1 : result_.trip_channel);
  record->stop_signal = static_cast<std::uint8_t>(result_.signal);
  record->wakeup_latency_ns = static_cast<std::int32_t>(
      std::clamp<std::int64_t>(wakeup_latency_, 0, INT32_MAX));
  record->overruns = overruns_so_far_;
  for (int k = 0; k < 3; ++k) {
    record->force[k] = measurement_.force(k);
    record->commanded[k] = command(k);
  }
  for (int k = 0; k < 6; ++k) record->y[k] = measurement_.y(k);
}

}  // namespace kcrig
