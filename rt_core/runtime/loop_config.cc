#include "rt_core/runtime/loop_config.h"

#include <string>
#include <utility>

#include "base/yaml_reader.h"
#include "rt_core/model/channels.h"

namespace kcrig {

namespace {

// Every limit has a range a rig can honour: a ramp-down of days, a travel
// limit of kilometres or a force limit beyond any actuator is a typo, and
// a typo here hurts the rig.
Status LoadSafetyLimits(const YamlReader& reader, const YAML::Node& root,
                        double period, SafetyLimits* limits) {
  YAML::Node safety;
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "safety", &safety));
  SafetyLimits& l = *limits;
  // A count of cycles that must span at most one second of the loop.
  auto within_a_second = [&](const char* key, int cycles) {
    return cycles * period <= 1.0
               ? Status::Ok()
               : reader.Error(safety[key], std::string("safety.") + key,
                              "must be at most 1 s of cycles (loop.period)");
  };
  double angle_max_deg = 0, error_angle_max_deg = 0;
  KCRIG_RETURN_IF_ERROR(
      reader.InRange(safety, "safety", "force_max", 1, 1e5, &l.force_max));
  KCRIG_RETURN_IF_ERROR(reader.InRange(safety, "safety", "force_rate_max", 1,
                                       1e7, &l.force_rate_max));
  KCRIG_RETURN_IF_ERROR(
      reader.InRange(safety, "safety", "travel_max", 1e-4, 0.5, &l.travel_max));
  KCRIG_RETURN_IF_ERROR(reader.InRange(safety, "safety", "angle_max_deg", 0.01,
                                       45, &angle_max_deg));
  KCRIG_RETURN_IF_ERROR(reader.InRange(safety, "safety", "error_position_max",
                                       1e-6, 0.5, &l.error_position_max));
  KCRIG_RETURN_IF_ERROR(reader.InRange(safety, "safety", "error_angle_max_deg",
                                       1e-4, 45, &error_angle_max_deg));
  KCRIG_RETURN_IF_ERROR(reader.Integer(safety, "safety", "watchdog_cycles", 1,
                                       100000, &l.watchdog_cycles));
  KCRIG_RETURN_IF_ERROR(within_a_second("watchdog_cycles", l.watchdog_cycles));
  KCRIG_RETURN_IF_ERROR(reader.InRange(safety, "safety", "ramp_down_time",
                                       period, 10, &l.ramp_down_time));
  KCRIG_RETURN_IF_ERROR(reader.InRange(safety, "safety", "force_error_max", 1,
                                       1e5, &l.force_error_max));
  KCRIG_RETURN_IF_ERROR(reader.Integer(safety, "safety", "force_error_cycles",
                                       1, 100000, &l.force_error_cycles));
  KCRIG_RETURN_IF_ERROR(
      within_a_second("force_error_cycles", l.force_error_cycles));
  // A force ramping at the rate limit leads the load cell by at least the
  // transport's two cycles (and by the actuator's lag on top: docs/rig.md,
  // safety), or a correct run trips.
  if (l.force_error_max <= 2 * period * l.force_rate_max) {
    return reader.Error(safety["force_error_max"], "safety.force_error_max",
                        "must exceed force_rate_max x 2 cycles (the command "
                        "leads the load cell)");
  }
  l.angle_max = angle_max_deg * kDegree;
  l.error_angle_max = error_angle_max_deg * kDegree;
  if (l.force_max / l.ramp_down_time > l.force_rate_max) {
    return reader.Error(safety["ramp_down_time"], "safety.ramp_down_time",
                        "a trip at force_max would ramp down faster than "
                        "force_rate_max allows");
  }
  return Status::Ok();
}

}  // namespace

Status CheckLimitsAtPeriod(const LoopConfig& config) {
  const double period = config.period;
  const SafetyLimits& l = config.safety;
  auto fail = [](const std::string& key, const std::string& why) {
    return Status::Error("rig.yaml " + key + ": " + why + " at this period");
  };
  for (const auto& [key, cycles] :
       {std::pair<const char*, int>{"safety.watchdog_cycles",
                                    l.watchdog_cycles},
        {"safety.force_error_cycles", l.force_error_cycles}}) {
    if (cycles * period > 1.0) {
      return fail(key, std::to_string(cycles) + " cycles are more than 1 s");
    }
  }
  for (const auto& [key, time] :
       {std::pair<const char*, double>{"safety.ramp_down_time",
                                       l.ramp_down_time},
        {"run_profile.tare", config.profile.tare},
        {"run_profile.lead_in", config.profile.lead_in},
        {"run_profile.ramp_down", config.profile.ramp_down}}) {
    if (time < period) return fail(key, "shorter than one cycle");
  }
  if (l.force_error_max <= 2 * period * l.force_rate_max) {
    return fail("safety.force_error_max",
                "does not exceed force_rate_max x 2 cycles");
  }
  return Status::Ok();
}

Status LoadLoopConfig(const YamlReader& reader, const YAML::Node& root,
                      LoopConfig* config) {
  YAML::Node loop, realtime, profile;
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
  KCRIG_RETURN_IF_ERROR(reader.InRange(profile, "run_profile", "tare",
                                       config->period, 60, &p.tare));
  KCRIG_RETURN_IF_ERROR(reader.InRange(profile, "run_profile", "lead_in",
                                       config->period, 60, &p.lead_in));
  KCRIG_RETURN_IF_ERROR(
      reader.InRange(profile, "run_profile", "settle", 0, 60, &p.settle));
  if (p.settle > 0 && p.settle < config->period) {
    return reader.Error(profile["settle"], "run_profile.settle",
                        "must be 0 or within [loop.period, 60] s");
  }
  KCRIG_RETURN_IF_ERROR(reader.InRange(profile, "run_profile", "ramp_down",
                                       config->period, 60, &p.ramp_down));
  return LoadSafetyLimits(reader, root, config->period, &config->safety);
}

}  // namespace kcrig
