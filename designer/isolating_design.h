// The next experiment that tells apart the faults a plan cannot: the
// isolability matrix (diagnosis/isolability.h) of the plan's logs or
// planned ramps names its ties; the design maximizes their mean
// separation (min(left(i, j), left(j, i)) over the tied pairs) with the
// new ramp added, over (phi, z_a) and the ramp's shape. Not the single
// smallest separation: two faults no ramp of the rig tells apart (the two
// ends of a link, often) would make it flat; with two candidates the two
// are the same.
#ifndef KCRIG_DESIGNER_ISOLATING_DESIGN_H_
#define KCRIG_DESIGNER_ISOLATING_DESIGN_H_

#include <string>
#include <utility>
#include <vector>

#include "base/status.h"
#include "designer/discrimination.h"
#include "diagnosis/isolability.h"
#include "estimator/experiment.h"
#include "rt_core/model/model_config.h"

namespace kcrig {

struct IsolatingDesignOptions {
  // The candidates and the separation a pair needs; its callback is asked
  // after each trial design's sensitivities.
  IsolabilityOptions isolability;
  // The ramp shapes tried and the evaluations per shape (each computes the
  // tied candidates' sensitivities on the trial ramp).
  DiscriminationOptions search;
};

struct IsolatingDesign {
  // The pairs of candidates the plan ties (their names).
  std::vector<std::pair<std::string, std::string>> ties;
  // With the designed ramp added: the ties it resolves, and the ties'
  // mean and smallest separation before and after.
  int resolved = 0;
  double mean_before = 0, mean_after = 0;
  double smallest_before = 0, smallest_after = 0;
  RampExcitation<double> excitation;  // valid when `ties` is not empty
  int evaluations = 0;
};

// Designs the ramp for `plan` (logs or planned experiments, at least one)
// within the design bounds of `config.experiment`, with its Fmax. No ties:
// `design->ties` stays empty and nothing is designed.
Status DesignIsolatingExperiment(const KcrigConfig& config,
                                 const std::vector<Experiment>& plan,
                                 const IsolatingDesignOptions& options,
                                 IsolatingDesign* design);

// The design as JSON (angles in deg, with the `kcrig run` / `kcrig
// simulate` options that perform it).
std::string IsolatingDesignToJson(const IsolatingDesign& design);

}  // namespace kcrig

#endif  // KCRIG_DESIGNER_ISOLATING_DESIGN_H_
