#include "designer/design_step.h"

#include <memory>

#include "designer/information.h"

namespace kcrig {

Status DesignStep(const KcrigConfig& config, const DesignStepOptions& options,
                  const Design& start, DesignRun* run) {
  const DesignBounds bounds{config.experiment.phi_bounds,
                            config.experiment.z_a_bounds};
  KCRIG_RETURN_IF_ERROR(DesignObjective::Validate(bounds, options.objective));
  std::unique_ptr<InformationEvaluator> evaluator;
  KCRIG_RETURN_IF_ERROR(InformationEvaluator::Create(
      config.model, options.names, options.values, config.experiment,
      options.prior_information, &evaluator));
  DesignObjective objective(evaluator.get(), options.criterion, bounds,
                            options.objective);
  KCRIG_RETURN_IF_ERROR(Optimize(options.optimizer, &objective, start,
                                 options.optimizer_options, &run->result));
  run->record = objective.record();
  return Status::Ok();
}

}  // namespace kcrig
