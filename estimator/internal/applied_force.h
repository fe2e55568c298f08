// The force the rig applied, recovered from its load cell's noisy reading
// and the loop's command, to drive the model of a rig log.
//
// Why: a hysteretic element (Dahl) driven by white noise goes through minor
// loops at every sample, and zero-mean jitter relaxes its state towards
// zero at a rate set by the distance it travels. The rig's actuator force
// is smooth; the load cell's noise is not in it. Driven by the raw reading,
// the model forgets a state the rig keeps (the state a previous run left),
// and its hysteresis bends wrong wherever the load moves slowly.
#ifndef KCRIG_ESTIMATOR_INTERNAL_APPLIED_FORCE_H_
#define KCRIG_ESTIMATOR_INTERNAL_APPLIED_FORCE_H_

#include <vector>

#include "rt_core/model/rotation.h"

namespace kcrig {

// Per axis: the actuator's linear response to the command (a causal FIR
// filter of `taps` samples fitted by least squares to the reading's changes
// from sample to sample, which holds the actuator's dead time and lag up to
// `taps` samples), plus a moving mean over 2 `half_width` + 1 samples of
// what that response leaves (slow force the command does not explain, e.g.
// the rig's reaction, and any offset). `measured` and `commanded` have one
// entry per sample; without (sizes that differ, taps < 1), `measured`.
std::vector<Vec3<double>> AppliedForce(
    const std::vector<Vec3<double>>& measured,
    const std::vector<Vec3<double>>& commanded, int taps, int half_width);

}  // namespace kcrig

#endif  // KCRIG_ESTIMATOR_INTERNAL_APPLIED_FORCE_H_
