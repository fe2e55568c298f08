// Rig safety in the style of servo-hydraulic controllers: limits on what is
// commanded (force, force rate), limits on what is measured (travel, angles),
// an error detector (measurement against the live model prediction) and a
// communication watchdog. Any trip latches: the force command ramps from its
// last value to zero over `ramp_down_time`, then the actuator is disabled.
// Everything here is allocation-free and runs inside the cycle.
#ifndef KCRIG_RT_CORE_RUNTIME_SAFETY_H_
#define KCRIG_RT_CORE_RUNTIME_SAFETY_H_

#include <cstdint>

#include "rt_core/model/rotation.h"

namespace kcrig {

struct SafetyLimits {
  double force_max = 5000;           // |set-point| per axis [N]
  double force_rate_max = 20000;     // |d set-point / dt| per axis [N/s]
  double travel_max = 0.02;          // |x|, |y|, |z| measured [m]
  double angle_max = 0.035;          // |toe|, |camber|, |caster| [rad]
  double error_position_max = 1e-3;  // |measured - predicted| [m]
  double error_angle_max = 5e-3;     // |measured - predicted| [rad]
  int watchdog_cycles = 20;          // consecutive cycles without a sample
  double ramp_down_time = 0.5;       // trip: force to zero over this [s]
  // Force tracking: the load cell off the last command by more than this
  // [N] on any axis for `force_error_cycles` consecutive fresh samples. The
  // rig is not following this controller (a second master, a stuck valve,
  // a broken load cell).
  double force_error_max = 500;
  int force_error_cycles = 50;
};

enum class TripCause : std::uint8_t {
  kNone = 0,
  kTravelLimit,
  kAngleLimit,
  kModelError,
  kWatchdog,
  kRigFault,
  kSignal,
  kInvalidMeasurement,
  kTransportFault,  // the bus failed (CAN bus-off, error-passive, tx timeout)
  kForceTracking,   // the measured force does not follow the command
  kForeignMaster,   // the rig obeys another master (transport's check)
  kLogWrite,        // the run's log could not be written (disk full)
};

const char* TripCauseName(TripCause cause);

enum class SafetyState : std::uint8_t {
  kNormal = 0,    // commands pass (limited)
  kRampDown = 1,  // tripped: ramping the force to zero
  kDisabled = 2,  // tripped and at zero: actuator disabled
};

class SafetyMonitor {
 public:
  SafetyMonitor(const SafetyLimits& limits, double period)
      : limits_(limits), period_(period) {}

  // Checks a fresh measurement against the travel and angle limits and,
  // with `detect_error`, against the model prediction (measured - rest vs
  // predicted, both relative to the rest pose). Returns the cause of the
  // first violated limit, or kNone; `channel` gets the channel index (x, y,
  // z, toe, camber, caster). A NaN violates every limit.
  TripCause CheckMeasurement(const Vec6<double>& measured,
                             const Vec6<double>& rest,
                             const Vec6<double>& predicted, bool detect_error,
                             int* channel) const;

  // Counts `cycles` cycles without a fresh sample (more than one when the
  // loop skipped cycles after an overrun); true when the watchdog expires.
  bool MissedSamples(int cycles) {
    missed_ += cycles;
    return missed_ >= limits_.watchdog_cycles;
  }
  void FreshSample() { missed_ = 0; }

  // Compares a fresh load-cell force with the last command sent (while
  // normal); true when it has been off by more than force_error_max for
  // force_error_cycles samples in a row. `axis` gets the worst axis.
  bool ForceOffCommand(const Vec3<double>& measured, int* axis);

  // Latches a trip (the first cause wins).
  void Trip(TripCause cause, std::int64_t cycle);

  // The command to send in `cycle`: the wanted force clamped to the force
  // limit and the rate limit while normal; once tripped, the ramp to zero
  // on time: (cycle - trip cycle + 1) periods into ramp_down_time, so that
  // cycles skipped by overruns do not stretch it.
  Vec3<double> Limit(const Vec3<double>& wanted, std::int64_t cycle);

  SafetyState state() const { return state_; }
  TripCause cause() const { return cause_; }
  std::int64_t trip_cycle() const { return trip_cycle_; }
  // Set-points that hit the force or rate limit.
  std::int64_t limited_commands() const { return limited_; }

 private:
  SafetyLimits limits_;
  double period_;
  int missed_ = 0;
  int force_off_ = 0;
  SafetyState state_ = SafetyState::kNormal;
  TripCause cause_ = TripCause::kNone;
  std::int64_t trip_cycle_ = -1;
  Vec3<double> last_ = Vec3<double>::Zero();
  Vec3<double> ramp_start_ = Vec3<double>::Zero();
  std::int64_t limited_ = 0;
};

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_RUNTIME_SAFETY_H_
