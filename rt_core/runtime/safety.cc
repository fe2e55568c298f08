#include "rt_core/runtime/safety.h"

#include <algorithm>
#include <cmath>

namespace kcrig {

const char* TripCauseName(TripCause cause) {
  switch (cause) {
    case TripCause::kNone:
      return "none";
    case TripCause::kTravelLimit:
      return "travel_limit";
    case TripCause::kAngleLimit:
      return "angle_limit";
    case TripCause::kModelError:
      return "error_detector";
    case TripCause::kWatchdog:
      return "watchdog";
    case TripCause::kRigFault:
      return "rig_fault";
    case TripCause::kSignal:
      return "signal";
    case TripCause::kInvalidMeasurement:
      return "invalid_measurement";
    case TripCause::kTransportFault:
      return "transport_fault";
    case TripCause::kForceTracking:
      return "force_tracking";
    case TripCause::kForeignMaster:
      return "foreign_master";
    case TripCause::kLogWrite:
      return "log_write_error";
  }
  return "unknown";
}

TripCause SafetyMonitor::CheckMeasurement(const Vec6<double>& measured,
                                          const Vec6<double>& rest,
                                          const Vec6<double>& predicted,
                                          bool detect_error,
                                          int* channel) const {
  for (int k = 0; k < 6; ++k) {
    *channel = k;
    const bool position = k < 3;
    if (!(std::abs(measured(k)) <=
          (position ? limits_.travel_max : limits_.angle_max))) {
      return position ? TripCause::kTravelLimit : TripCause::kAngleLimit;
    }
  }
  for (int k = 0; detect_error && k < 6; ++k) {
    *channel = k;
    const double limit =
        k < 3 ? limits_.error_position_max : limits_.error_angle_max;
    if (!(std::abs(measured(k) - rest(k) - predicted(k)) <= limit)) {
      return TripCause::kModelError;
    }
  }
  *channel = -1;
  return TripCause::kNone;
}

void SafetyMonitor::Trip(TripCause cause, std::int64_t cycle) {
  if (state_ != SafetyState::kNormal) return;
  state_ = SafetyState::kRampDown;
  cause_ = cause;
  trip_cycle_ = cycle;
  ramp_start_ = last_;
}

bool SafetyMonitor::ForceOffCommand(const Vec3<double>& measured, int* axis) {
  if (state_ != SafetyState::kNormal) return false;
  double worst = 0;
  for (int k = 0; k < 3; ++k) {
    const double off = std::abs(measured(k) - last_(k));
    if (off > worst) {
      worst = off;
      *axis = k;
    }
  }
  force_off_ = worst > limits_.force_error_max ? force_off_ + 1 : 0;
  return force_off_ >= limits_.force_error_cycles;
}

Vec3<double> SafetyMonitor::Limit(const Vec3<double>& wanted,
                                  std::int64_t cycle) {
  if (state_ == SafetyState::kNormal) {
    const double step = limits_.force_rate_max * period_;
    Vec3<double> out;
    bool limited = false;
    for (int k = 0; k < 3; ++k) {
      double value =
          std::clamp(wanted(k), -limits_.force_max, limits_.force_max);
      value = std::clamp(value, last_(k) - step, last_(k) + step);
      limited |= value != wanted(k);
      out(k) = std::isfinite(value) ? value : last_(k);
    }
    limited_ += limited;
    last_ = out;
    return out;
  }
  if (state_ == SafetyState::kRampDown) {
    // In double: no cycle count to overflow, whatever ramp_down_time is.
    const double elapsed =
        static_cast<double>(cycle - trip_cycle_ + 1) * period_;
    double remaining =
        std::clamp(1.0 - elapsed / limits_.ramp_down_time, 0.0, 1.0);
    if (remaining < 1e-9) remaining = 0;  // the last period's rounding
    last_ = ramp_start_ * remaining;
    if (remaining == 0.0) state_ = SafetyState::kDisabled;
    return last_;
  }
  last_.setZero();
  return last_;
}

}  // namespace kcrig
