#include "rt_core/model/excitation.h"

namespace kcrig {

const char* RunPhaseName(RunPhase phase) {
  switch (phase) {
    case RunPhase::kTare:
      return "tare";
    case RunPhase::kLeadIn:
      return "lead_in";
    case RunPhase::kSettle:
      return "settle";
    case RunPhase::kRamp:
      return "ramp";
    case RunPhase::kHold:
      return "hold";
    case RunPhase::kReturn:
      return "return";
    case RunPhase::kRampDown:
      return "ramp_down";
    case RunPhase::kDone:
      return "done";
  }
  return "unknown";
}

std::string_view RunPhaseNamed(std::string_view text) {
  for (int k = 0; k <= static_cast<int>(RunPhase::kDone); ++k) {
    const char* name = RunPhaseName(static_cast<RunPhase>(k));
    if (text == name) return name;
  }
  return {};
}

RunProfile::RunProfile(const RunProfileTimes& times,
                       const RampExcitation<double>& excitation)
    : excitation_{0.0,
                  0.0,
                  1.0,
                  excitation.duration,
                  excitation.hold,
                  excitation.return_duration} {
  const double durations[kNumPhases] = {
      times.tare,          times.lead_in,   times.settle,
      excitation.duration, excitation.hold, excitation.return_duration,
      times.ramp_down};
  // The levels at the ends of the phases around the excitation's.
  const double levels[kNumPhases] = {
      0.0, -1.0, -1.0, 1.0, 1.0, excitation_.Profile(excitation_.EndTime()),
      0.0};
  double end = 0;
  for (int k = 0; k < kNumPhases; ++k) {
    end += durations[k];
    end_[k] = end;
    level_[k] = levels[k];
  }
}

RunPhase RunProfile::Phase(double t) const {
  for (int k = 0; k < kNumPhases; ++k) {
    if (t < end_[k]) return static_cast<RunPhase>(k);
  }
  return RunPhase::kDone;
}

double RunProfile::Level(double t) const {
  // The ramp, hold and return are the excitation's own segments.
  const int first = static_cast<int>(RunPhase::kRamp);
  const int last = static_cast<int>(RunPhase::kReturn);
  if (t >= end_[first - 1] && t < end_[last]) {
    return excitation_.Profile(t - ramp_start());
  }
  double start = 0, start_level = 0;
  for (int k = 0; k < kNumPhases; ++k) {
    if (t < end_[k]) {
      const double span = end_[k] - start;
      return start_level + (level_[k] - start_level) * (t - start) / span;
    }
    start = end_[k];
    start_level = level_[k];
  }
  return 0.0;
}

}  // namespace kcrig
