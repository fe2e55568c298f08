// One design step, the same for `kcrig design` and the campaign: the
// information evaluator at the current parameter values (plus the prior
// information of the data so far, if any), the objective over the config's
// design bounds, and one optimizer from a start design.
#ifndef KCRIG_DESIGNER_DESIGN_STEP_H_
#define KCRIG_DESIGNER_DESIGN_STEP_H_

#include <memory>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "base/status.h"
#include "designer/criteria.h"
#include "designer/design_io.h"
#include "designer/design_objective.h"
#include "designer/information.h"
#include "designer/optimizers.h"
#include "rt_core/model/model_config.h"

namespace kcrig {

struct DesignStepOptions {
  // The estimated parameters and the values to design at.
  std::vector<std::string> names;
  std::vector<double> values;
  // The information of the data so far (est.json's information_matrix, as
  // InformationEvaluator::Create takes it); empty: the design alone.
  Eigen::MatrixXd prior_information;
  Criterion criterion = Criterion::kD;
  std::string optimizer = "imfil";  // as Optimize takes it
  ObjectiveOptions objective;
  OptimizerOptions optimizer_options;
};

// The objective a design step searches, over config.experiment's bounds
// (the objective refers to the evaluator): what DesignStep optimizes and
// ComputeCriterionSurface draws.
struct StepObjective {
  std::unique_ptr<InformationEvaluator> evaluator;
  std::unique_ptr<DesignObjective> objective;
};
Status MakeStepObjective(const KcrigConfig& config,
                         const DesignStepOptions& options, StepObjective* step);

// Runs `options.optimizer` from `start` over config.experiment's bounds;
// `run` gets the result and every evaluation.
Status DesignStep(const KcrigConfig& config, const DesignStepOptions& options,
                  const Design& start, DesignRun* run);

}  // namespace kcrig

#endif  // KCRIG_DESIGNER_DESIGN_STEP_H_
