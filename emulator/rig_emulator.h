// The software rig: what `kcrig emulate` serves. A force-controlled
// hydraulic actuator (set-point clamp, dead time, first-order lag), the true
// plant with its unmodelled effects (rt_core/model/rig_plant.h) integrated at
// the plant's fine step up to the time its front end gives (on the clock of
// rt_core/runtime/clock.h), sensors with offset, noise and quantization, a load
// cell, and the rig's own protection: a travel limit and a command watchdog
// that fault the rig and ramp its force to zero, and one master at a time
// (rig_ownership.h). Transport-free: front ends call AdvanceTo, Request and
// TakeSample.
#ifndef KCRIG_EMULATOR_RIG_EMULATOR_H_
#define KCRIG_EMULATOR_RIG_EMULATOR_H_

#include <atomic>
#include <cstdint>
#include <random>
#include <vector>

#include "emulator/plant_config.h"
#include "emulator/rig_ownership.h"
#include "rt_core/model/model_config.h"
#include "rt_core/model/plant_effects.h"
#include "rt_core/model/rig_plant.h"
#include "rt_core/runtime/rig_interface.h"

namespace kcrig {

// A command as a session-aware front end receives it.
struct RigRequest {
  RigCommand command;
  bool reset_fault = false;
  RigOwnership::Request ownership;
};

class RigEmulator {
 public:
  RigEmulator(const KcrigConfig& config, const PlantConfig& plant,
              const PlantEffects& effects);

  // At rest at zero force, time `now` [s].
  Status Start(double now);

  // Integrates the rig up to `now` [s] (monotonic, any origin).
  void AdvanceTo(double now);

  // A request received at the current time: obeyed when its session may
  // command the rig (then as ApplyCommand; a release also disables), else
  // refused and counted. Returns whether it was obeyed.
  bool Request(const RigRequest& request);

  // A front end's connection closed: if it was the owner's, the claim ends
  // and an enabled rig faults (kFaultOwnerLost) and ramps its force down.
  void ConnectionClosed(int connection);

  // The rig's own emergency stop (its operator's button): it faults and
  // ramps its force down, whatever its master commands; no reset clears
  // the fault until the button is released at the rig.
  void EmergencyStop();
  void ReleaseEmergencyStop() { emergency_stop_pressed_ = false; }
  // Buttons pressed from another thread (kcrig emulate: SIGUSR1 stop,
  // SIGUSR2 release), seen at the next AdvanceTo. Optional.
  enum Button : int { kButtonNone = 0, kButtonStop = 1, kButtonRelease = 2 };
  void WireEmergencyStop(std::atomic<int>* button) { button_ = button; }

  // Takes one sample of every sensor (sample counter + 1).
  RigMeasurement TakeSample();

  std::uint16_t status() const;
  std::uint16_t fault() const { return fault_; }
  std::uint16_t last_sequence() const { return last_sequence_; }
  const RigOwnership& ownership() const { return ownership_; }
  const RigPlant& plant() const { return plant_; }
  // The force the actuator applies now [N].
  const Vec3<double>& actuator_force() const { return actuator_force_; }

 private:
  void Step();
  void ApplyCommand(const RigCommand& command, bool reset_fault);
  void Fault(RigFaultCode code);
  void LoseOwner(RigFaultCode code);
  double Quantize(double value, double resolution) const;

  PlantConfig config_;
  ExperimentConfig experiment_;
  RigPlant plant_;
  double time_ = 0;          // plant time [s]
  double last_command_ = 0;  // time of the last command [s]
  bool enabled_ = false;
  bool limited_ = false;
  std::uint16_t fault_ = kFaultNone;
  double fault_time_ = 0;
  Vec3<double> fault_setpoint_ = Vec3<double>::Zero();
  Vec3<double> setpoint_ = Vec3<double>::Zero();
  Vec3<double> actuator_force_ = Vec3<double>::Zero();
  std::vector<Vec3<double>> dead_time_line_;
  size_t dead_time_head_ = 0;
  double lag_gain_ = 1;
  std::uint32_t sample_ = 0;
  std::uint16_t last_sequence_ = 0;
  RigOwnership ownership_;
  std::atomic<int>* button_ = nullptr;
  bool emergency_stop_pressed_ = false;
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
};

}  // namespace kcrig

#endif  // KCRIG_EMULATOR_RIG_EMULATOR_H_
