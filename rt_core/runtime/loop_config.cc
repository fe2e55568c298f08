#include "rt_core/runtime/loop_config.h"

#include "base/yaml_reader.h"
#include "rt_core/model/channels.h"

namespace kcrig {

Status LoadLoopConfig(const YamlReader& reader, const YAML::Node& root,
                      LoopConfig* config) {
  YAML::Node loop, realtime, profile, safety;
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "loop", &loop));
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(loop, "loop", "period", &config->period));
  if (config->period < 1e-4 || config->period > 0.1) {
    return reader.Error(loop["period"], "loop.period",
                        "must be within [0.0001, 0.1] s");
  }
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "realtime", &realtime));
  KCRIG_RETURN_IF_ERROR(reader.Integer(realtime, "realtime", "priority", 0, 99,
                                       &config->realtime.priority));
  KCRIG_RETURN_IF_ERROR(reader.Integer(realtime, "realtime", "cpu", -1, 1023,
                                       &config->realtime.cpu));
  KCRIG_RETURN_IF_ERROR(reader.Boolean(realtime, "realtime", "lock_memory",
                                       &config->realtime.lock_memory));
  KCRIG_RETURN_IF_ERROR(reader.Boolean(realtime, "realtime", "no_cpu_idle",
                                       &config->realtime.no_cpu_idle));
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "run_profile", &profile));
  RunProfileTimes& p = config->profile;
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(profile, "run_profile", "tare", &p.tare));
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(profile, "run_profile", "lead_in", &p.lead_in));
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(profile, "run_profile", "settle", &p.settle, false));
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(profile, "run_profile", "ramp_down", &p.ramp_down));

  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "safety", &safety));
  SafetyLimits& l = config->safety;
  double angle_max_deg = 0, error_angle_max_deg = 0;
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(safety, "safety", "force_max", &l.force_max));
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(safety, "safety", "force_rate_max", &l.force_rate_max));
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(safety, "safety", "travel_max", &l.travel_max));
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(safety, "safety", "angle_max_deg", &angle_max_deg));
  KCRIG_RETURN_IF_ERROR(reader.Positive(safety, "safety", "error_position_max",
                                        &l.error_position_max));
  KCRIG_RETURN_IF_ERROR(reader.Positive(safety, "safety", "error_angle_max_deg",
                                        &error_angle_max_deg));
  KCRIG_RETURN_IF_ERROR(reader.Integer(safety, "safety", "watchdog_cycles", 1,
                                       100000, &l.watchdog_cycles));
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(safety, "safety", "ramp_down_time", &l.ramp_down_time));
  l.angle_max = angle_max_deg * kDegree;
  l.error_angle_max = error_angle_max_deg * kDegree;
  if (l.force_max / l.ramp_down_time > l.force_rate_max) {
    return reader.Error(safety["ramp_down_time"], "safety.ramp_down_time",
                        "a trip at force_max would ramp down faster than "
                        "force_rate_max allows");
  }

  return Status::Ok();
}

}  // namespace kcrig
