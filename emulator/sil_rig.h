// The software-in-the-loop rig (`--rig sim`): the emulator's rig core
// (rig_emulator.h: actuator, true plant with its effects, sensors, load
// cell, the rig's own protection) connected to the control loop in-process,
// without a transport, on a virtual clock that the loop's sleeps advance.
// A run on it is a HIL run (the loop, safety, phases, logger, run.csv and
// run.json) that goes as fast as the CPU allows, the same for a seed on any
// machine, with no real-time privileges. One SilRig lives as long as a
// campaign or a series of runs: the plant's state (a bushing's hysteresis,
// a structure still relaxing) carries over from run to run, as on a rig,
// with plant.yaml's rig.rest_between_runs between them (rig.keeps_state
// false: each run starts from rest instead).
#ifndef KCRIG_EMULATOR_SIL_RIG_H_
#define KCRIG_EMULATOR_SIL_RIG_H_

#include <cstdint>
#include <memory>
#include <vector>

#include "emulator/injected_fault.h"
#include "emulator/plant_config.h"
#include "emulator/rig_emulator.h"
#include "records/run_log.h"
#include "rt_core/model/model_config.h"
#include "rt_core/runtime/clock.h"
#include "rt_core/runtime/rig_interface.h"

namespace kcrig {

class SilRig {
 public:
  SilRig(const KcrigConfig& config, const PlantConfig& plant);

  // The rig at rest at zero force (the plant settled), time 0.
  Status Start();

  // The loop's link to the rig for one run, injecting `faults` (at the
  // link's reads, counted from 0). Its Activate starts the run, after the
  // rest since the last one; a link never activated (a probe) changes
  // nothing. The link must not outlive the rig.
  std::unique_ptr<RigInterface> Connect(std::vector<InjectedFault> faults);

  // The time the loop must run on.
  VirtualClock* clock() { return &clock_; }

  // The rig's true state (its actuator's force, its status), for what a
  // test or a rehearsal observes beyond the loop's view.
  const RigEmulator& emulator() const { return emulator_; }

  // What a log's sidecar records of the rig: its true parameters and
  // effects, that its sensors add noise, and the noise seed.
  RunMetadata Truth() const;

 private:
  // A run begins: the rest since the last one (from rest again when the
  // plant keeps no state), and the run's session token.
  Status BeginRun(std::uint16_t* session);

  PlantConfig plant_;
  VirtualClock clock_;
  RigEmulator emulator_;
  std::uint16_t next_session_ = 1;
  bool ran_ = false;  // a run began: the next one rests first
};

}  // namespace kcrig

#endif  // KCRIG_EMULATOR_SIL_RIG_H_
