// The blind cases of `kcrig validate` (and of the blind diagnosis tests): a
// seeded generator draws the truth of each case — one of the six library
// effects, none, or a wrong "known" parameter (a hard point off along one
// axis, or the spring rate) — its magnitude from small to large, where a
// bushing effect acts (one case in two a single bushing, a worn one; else
// every bushing), the rig's
// true bushings (+-10 % off the configured ones, as a real rig's are), the
// designs of two training logs and one hold-out log (or those of a test
// plan), and the noise seeds.
// The same (index, seed) gives the same case on any machine and rank.
#ifndef KCRIG_VALIDATION_BLIND_CASE_H_
#define KCRIG_VALIDATION_BLIND_CASE_H_

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "Eigen/Core"
#include "base/status.h"
#include "rt_core/model/excitation.h"
#include "rt_core/model/plant_effects.h"
#include "rt_core/model/suspension_parameters.h"

namespace kcrig {

// The truths a case is drawn from, in the order cases cycle through them.
inline const std::vector<std::string>& BlindCaseClasses() {
  static const std::vector<std::string> classes = {"bushing_damping",
                                                   "hysteresis",
                                                   "progressive_stiffness",
                                                   "actuator_lag",
                                                   "rig_compliance",
                                                   "sensor_offset",
                                                   "none",
                                                   "model_parameter"};
  return classes;
}

struct BlindDesign {
  double phi_deg = 0, z_a = 0, duration = 0, hold = 0, return_duration = 0;
  RampExcitation<double> Ramp(double fmax) const;
  // As `kcrig simulate` takes it: --phi .. --return ...
  std::string Arguments() const;
};

// Most logs of a case (training and hold-out). Cases' noise seeds are this
// far apart (the rig's noise stream of a case starts at its seed).
inline constexpr int kMaxPlanLogs = 64;

// The experiments a user will run: every case's logs take these designs
// (empty: each case draws its own).
struct BlindTestPlan {
  std::vector<BlindDesign> training, holdout;
};

// A plan file (YAML): `training:` and `holdout:` lists of ramps
// {phi_deg, z_a [m], duration [s], hold [s], return [s]}; 1 to 32 training
// ramps, 0 to 32 hold-out ramps. Errors name file, line and key.
Status LoadBlindTestPlan(const std::string& file, BlindTestPlan* plan);

struct BlindCase {
  int index = 0;
  std::string truth;     // one of BlindCaseClasses()
  std::string effect;    // the --effect text of a library effect, or ""
  double magnitude = 0;  // 0..1, small to large (log scale in a range)
  PlantEffects effects;  // parsed from `effect`
  // Where a bushing effect acts, in the component vocabulary
  // (plant_effects.h) and bushing order: one bushing, or all five; empty
  // for the other truths.
  std::vector<std::string> components;
  // The plant's parameters that differ from the configuration: the true
  // bushings, and a wrong "known" parameter.
  std::vector<std::pair<std::string, double>> sets;
  // model_parameter: the one that is off (k_spring, or a hard point such
  // as O1, moved in 3D)...
  std::string parameter;
  // ...and its true value (for a point, the length of its move)...
  double parameter_value = 0;
  // ...and a point's move [m], x y z.
  Eigen::Vector3d point_move = Eigen::Vector3d::Zero();
  // The logs' designs: the training logs, then the hold-out logs.
  std::vector<BlindDesign> training, holdout;
  std::uint64_t noise_seed = 0;  // of the rig's sensors, over all its logs
  // The truth as `kcrig simulate` options (--effect ... --set ...).
  std::string Arguments() const;
};

// Case `index` of the series `seed` for the configured `model`. `classes`
// (of BlindCaseClasses(); empty: all) are cycled through instead. The
// designs are drawn (two training logs, one hold-out) unless `plan` gives
// them (the same draws otherwise). Errors on an unknown class.
Status DrawBlindCase(int index, std::uint64_t seed,
                     const SuspensionParameters<double>& model,
                     const std::vector<std::string>& classes,
                     const BlindTestPlan& plan, BlindCase* blind_case);

// The configured model with the case's parameters set: the rig's plant.
SuspensionParameters<double> BlindCasePlant(
    const BlindCase& blind_case, const SuspensionParameters<double>& model);

}  // namespace kcrig

#endif  // KCRIG_VALIDATION_BLIND_CASE_H_
