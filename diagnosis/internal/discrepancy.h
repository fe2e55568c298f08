// What the missing force looks like when no candidate of the library
// explains the gap (SINDy-style sparse regression): a force in each element
// (the five bushings and the strut) as a sparse combination of named
// functions of its elongation d, its rate v and time, through the
// suspension's quasi-static response.
//
// Along the nominal fit's trajectory, an extra tension f_e in element e
// moves the pose by -(dQ/dy)^-1 a_e f_e (a_e the element's generalized
// direction): on the slow K&C ramps the dynamic part of the response is
// far below the static one. So the weighted residual is regressed on the
// columns  response_e(t) * term(d_e(t), v_e(t), t)  for the terms
//   d (the strut only: the bushings' own d is their stiffness, refitted
//   with every selection), d^2, d^3, sign(d), v, sign(v), t*d,
// sign(x) a tanh over a twentieth of x's RMS. Forward selection adds the
// term that best predicts each fitted log from the others (blocked
// cross-validation; with one log, the term that lowers the residual sum
// of squares most) while it lowers that sum by more than the BIC's price
// ln(m) + min_bic_difference and, with two or more logs, the
// cross-validated one by min_bic_difference, up to max_terms; the chosen
// terms are then scored on logs they were not fitted to (a gap closed
// there only when the gap exceeds five standard deviations of a score at
// the noise floor).
#ifndef KCRIG_DIAGNOSIS_INTERNAL_DISCREPANCY_H_
#define KCRIG_DIAGNOSIS_INTERNAL_DISCREPANCY_H_

#include <vector>

#include "base/status.h"
#include "diagnosis/diagnosis.h"
#include "estimator/effect_model.h"
#include "estimator/experiment.h"

namespace kcrig {

// `model` at `values` is the nominal fit to `training`. The terms are
// validated on `validation` when given; else, with two or more training
// logs, selected on all but the last and validated on it; else not.
Status CharacteriseDiscrepancy(const EffectModel& model,
                               const std::vector<double>& values,
                               const std::vector<Experiment>& training,
                               const std::vector<Experiment>& validation,
                               double integrator_step,
                               const DiscrepancyOptions& options,
                               Discrepancy* discrepancy);

}  // namespace kcrig

#endif  // KCRIG_DIAGNOSIS_INTERNAL_DISCREPANCY_H_
