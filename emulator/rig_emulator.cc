#include "emulator/rig_emulator.h"

#include <algorithm>
#include <cmath>

namespace kcrig {

RigEmulator::RigEmulator(const KcrigConfig& config, const PlantConfig& plant,
                         const PlantEffects& effects)
    : config_(plant),
      experiment_(config.experiment),
      plant_(plant.model, effects, plant.step),
      rng_(plant.seed) {
  const auto delay_steps =
      static_cast<size_t>(std::lround(plant.actuator_dead_time / plant.step));
  dead_time_line_.assign(delay_steps + 1, Vec3<double>::Zero());
  lag_gain_ = -std::expm1(-plant.step / plant.actuator_tau);
}

Status RigEmulator::Start(double now) {
  time_ = now;
  last_command_ = now;
  return plant_.Settle(Vec3<double>::Zero(), 0.0);
}

void RigEmulator::Fault(RigFaultCode code) {
  if (fault_ != kFaultNone) return;
  fault_ = code;
  fault_time_ = time_;
  // A disabled rig applies no set-point: its fault ramps from nothing.
  fault_setpoint_ = enabled_ ? setpoint_ : Vec3<double>::Zero();
}

void RigEmulator::Step() {
  // Own protection first: a silent controller or a pose beyond travel.
  if (enabled_ && time_ - last_command_ > config_.command_timeout) {
    Fault(kFaultCommandTimeout);
  }
  if (ownership_.Expire(time_, config_.claim_timeout)) {
    LoseOwner(kFaultCommandTimeout);
  }
  Vec3<double> demand = enabled_ ? setpoint_ : Vec3<double>::Zero();
  if (fault_ != kFaultNone) {
    const double remaining =
        std::max(0.0, 1.0 - (time_ - fault_time_) / config_.ramp_down_time);
    demand = fault_setpoint_ * remaining;
  }
  // Actuator: dead time, then a first-order lag.
  dead_time_line_[dead_time_head_] = demand;
  dead_time_head_ = (dead_time_head_ + 1) % dead_time_line_.size();
  actuator_force_ +=
      lag_gain_ * (dead_time_line_[dead_time_head_] - actuator_force_);
  plant_.Step(actuator_force_);
  time_ += config_.step;
  if (!plant_.Finite(1.0)) {
    Fault(kFaultDiverged);
    plant_.Settle(Vec3<double>::Zero(), 0.0);
    actuator_force_.setZero();
  } else if (plant_.pose().head<3>().cwiseAbs().maxCoeff() >
             config_.travel_max) {
    Fault(kFaultTravel);
  }
}

void RigEmulator::AdvanceTo(double now) {
  while (time_ + config_.step <= now) Step();
  if (button_ == nullptr) return;
  const int pressed = button_->exchange(kButtonNone);
  if (pressed == kButtonStop) EmergencyStop();
  if (pressed == kButtonRelease) ReleaseEmergencyStop();
}

void RigEmulator::EmergencyStop() {
  emergency_stop_pressed_ = true;
  Fault(kFaultEmergencyStop);
}

// An unclaimed rig is never enabled: one that was faults and ramps down.
void RigEmulator::LoseOwner(RigFaultCode code) {
  if (enabled_) Fault(code);
  enabled_ = false;
}

bool RigEmulator::Request(const RigRequest& request) {
  switch (ownership_.Decide(request.ownership, time_)) {
    case RigOwnership::Verdict::kRefuse:
      return false;
    case RigOwnership::Verdict::kObeyAndRelease: {
      RigCommand disable = request.command;
      disable.enable = false;
      ApplyCommand(disable, request.reset_fault);
      return true;
    }
    case RigOwnership::Verdict::kObey:
      // Only the owner resets a fault (an unclaimed rig obeys disabled
      // commands from anyone).
      ApplyCommand(request.command,
                   request.reset_fault && ownership_.owner() != 0);
      return true;
  }
  return false;
}

void RigEmulator::ConnectionClosed(int connection) {
  if (ownership_.ConnectionClosed(connection)) LoseOwner(kFaultOwnerLost);
}

void RigEmulator::ApplyCommand(const RigCommand& command, bool reset_fault) {
  last_command_ = time_;
  last_sequence_ = command.sequence;
  // An emergency stop stays until it is released at the rig.
  if (reset_fault && fault_ != kFaultNone && !emergency_stop_pressed_ &&
      actuator_force_.norm() < 1.0) {
    fault_ = kFaultNone;
  }
  enabled_ = command.enable;
  limited_ = false;
  for (int k = 0; k < 3; ++k) {
    const double value = command.force(k);
    const double clamped = std::isfinite(value)
                               ? std::clamp(value, -config_.actuator_force_max,
                                            config_.actuator_force_max)
                               : 0.0;
    limited_ |= clamped != value;
    setpoint_(k) = clamped;
  }
  if (std::isfinite(command.z_a) && std::abs(command.z_a) <= 2.0) {
    plant_.set_z_a(command.z_a);
  }
}

double RigEmulator::Quantize(double value, double resolution) const {
  return resolution > 0 ? std::round(value / resolution) * resolution : value;
}

RigMeasurement RigEmulator::TakeSample() {
  RigMeasurement m;
  m.sample = ++sample_;
  const Vec6<double> sensed = plant_.Sensed() + config_.sensor_offset;
  for (int k = 0; k < 6; ++k) {
    const bool position = k < 3;
    const double sigma =
        position ? experiment_.sigma_position : experiment_.sigma_angle;
    const double noisy =
        sensed(k) + (config_.noise ? sigma * normal_(rng_) : 0.0);
    m.y(k) = Quantize(noisy, position ? config_.position_resolution
                                      : config_.angle_resolution);
  }
  for (int k = 0; k < 3; ++k) {
    const double noisy =
        actuator_force_(k) +
        (config_.noise ? config_.load_cell_sigma * normal_(rng_) : 0.0);
    m.force(k) = Quantize(noisy, config_.load_cell_resolution);
  }
  m.status = status();
  m.fault_code = fault_;
  return m;
}

std::uint16_t RigEmulator::status() const {
  std::uint16_t status = 0;
  if (enabled_ && fault_ == kFaultNone) status |= kRigEnabled;
  if (fault_ != kFaultNone) status |= kRigFault;
  if (limited_) status |= kRigLimit;
  if (fault_ == kFaultCommandTimeout) status |= kRigWatchdog;
  return status;
}

}  // namespace kcrig
