#include "designer/design_step.h"

namespace kcrig {

Status MakeStepObjective(const KcrigConfig& config,
                         const DesignStepOptions& options,
                         StepObjective* step) {
  const DesignBounds bounds{config.experiment.phi_bounds,
                            config.experiment.z_a_bounds};
  KCRIG_RETURN_IF_ERROR(DesignObjective::Validate(bounds, options.objective));
  KCRIG_RETURN_IF_ERROR(InformationEvaluator::Create(
      config.model, options.names, options.values, config.experiment,
      options.prior_information, &step->evaluator));
  step->objective = std::make_unique<DesignObjective>(
      step->evaluator.get(), options.criterion, bounds, options.objective);
  return Status::Ok();
}

Status DesignStep(const KcrigConfig& config, const DesignStepOptions& options,
                  const Design& start, DesignRun* run) {
  StepObjective step;
  KCRIG_RETURN_IF_ERROR(MakeStepObjective(config, options, &step));
  KCRIG_RETURN_IF_ERROR(Optimize(options.optimizer, step.objective.get(), start,
                                 options.optimizer_options, &run->result));
  run->record = step.objective->record();
  return Status::Ok();
}

}  // namespace kcrig
