#include "designer/criterion_surface.h"

#include <memory>

#include "designer/design_objective.h"

namespace kcrig {

Status ComputeCriterionSurface(const KcrigConfig& config,
                               const DesignStepOptions& step,
                               const std::vector<Criterion>& criteria,
                               const SurfaceOptions& options,
                               CriterionSurface* surface) {
  const int np = options.phi_points;
  const int nz = options.z_points;
  if (criteria.empty() || np < 2 || nz < 2) {
    return Status::Error(
        "criterion surface: needs a criterion and at least 2 x 2 points");
  }
  DesignStepOptions surface_step = step;
  surface_step.criterion = criteria[0];
  surface_step.objective = ObjectiveOptions();
  surface_step.objective.budget =
      np * nz + static_cast<int>(options.points.size());
  surface_step.objective.num_threads = step.objective.num_threads;
  StepObjective made;
  KCRIG_RETURN_IF_ERROR(MakeStepObjective(config, surface_step, &made));
  DesignObjective& objective = *made.objective;
  // The grid in the optimizers' unit coordinates (as the grid search lays
  // it out), then the extra designs: one parallel batch.
  std::vector<Eigen::Vector2d> units;
  for (int j = 0; j < nz; ++j) {
    for (int i = 0; i < np; ++i) {
      units.emplace_back(static_cast<double>(i) / (np - 1),
                         static_cast<double>(j) / (nz - 1));
    }
  }
  for (const Design& design : options.points) {
    units.push_back(objective.ToUnit(design));
  }
  const std::vector<DesignEvaluation> evaluations = objective.Evaluate(units);
  *surface = CriterionSurface();
  surface->criteria = criteria;
  for (int i = 0; i < np; ++i) {
    surface->phi.push_back(evaluations[i].design.phi);
  }
  for (int j = 0; j < nz; ++j) {
    surface->z_a.push_back(evaluations[j * np].design.z_a);
  }
  for (Criterion criterion : criteria) {
    std::vector<double>& grid = surface->grid.emplace_back();
    std::vector<double>& at = surface->at_points.emplace_back();
    for (size_t k = 0; k < evaluations.size(); ++k) {
      const double value =
          EvaluateCriterion(criterion, evaluations[k].information).value;
      (static_cast<int>(k) < np * nz ? grid : at).push_back(value);
    }
  }
  return Status::Ok();
}

}  // namespace kcrig
