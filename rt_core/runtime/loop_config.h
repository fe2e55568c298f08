// The loop's settings in rig.yaml (loop, realtime, run_profile, safety),
// loaded and range-checked here, where they are used.
#ifndef KCRIG_RT_CORE_RUNTIME_LOOP_CONFIG_H_
#define KCRIG_RT_CORE_RUNTIME_LOOP_CONFIG_H_

#include "base/status.h"
#include "rt_core/model/excitation.h"
#include "rt_core/runtime/realtime.h"
#include "rt_core/runtime/safety.h"

namespace YAML {
class Node;
}

namespace kcrig {

class YamlReader;

struct LoopConfig {
  double period = 1e-3;  // [s]
  RealtimeOptions realtime;
  RunProfileTimes profile;
  SafetyLimits safety;
};

// The limits that LoadLoopConfig checks against loop.period, checked again
// for a period set after loading (timing-check --rate): counts of cycles
// within 1 s, times of at least one cycle, force tracking's band beyond two
// cycles at the rate limit. The error names the rig.yaml key.
Status CheckLimitsAtPeriod(const LoopConfig& config);

// Reads the sections loop, realtime, run_profile and safety of `root`.
Status LoadLoopConfig(const YamlReader& reader, const YAML::Node& root,
                      LoopConfig* loop_config);

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_RUNTIME_LOOP_CONFIG_H_
