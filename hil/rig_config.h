// The controller's settings (config/rig.yaml): the loop's, the timing
// budget of timing-check and the transports', each section loaded by the
// library that owns it.
#ifndef KCRIG_HIL_RIG_CONFIG_H_
#define KCRIG_HIL_RIG_CONFIG_H_

#include <string>

#include "base/status.h"
#include "io_drivers/transport_config.h"
#include "rt_core/runtime/loop_config.h"

namespace kcrig {

struct TimingBudget {
  double compute_p999_fraction = 0.2;  // of the period
  double wakeup_p99 = 5e-4;            // [s]
  double cycle_p999_fraction = 0.8;    // of the period
  double overrun_max_fraction = 1e-3;  // of the cycles
};

struct RigConfig : LoopConfig {
  TimingBudget budget;
  ModbusSettings modbus;
  CanSettings can;
};

Status LoadRigConfig(const std::string& directory, RigConfig* rig);

}  // namespace kcrig

#endif  // KCRIG_HIL_RIG_CONFIG_H_
