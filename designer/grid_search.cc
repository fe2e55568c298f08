#include <vector>

#include "designer/optimizers.h"

namespace kcrig {

Status GridSearch(DesignObjective* objective, const OptimizerOptions& options,
                  OptimizationResult* result) {
  const int np = options.grid_phi_points;
  const int nz = options.grid_z_points;
  if (np < 2 || nz < 2) {
    return Status::Error("grid: at least 2 points along phi and along z_a");
  }
  std::vector<Eigen::Vector2d> points;
  for (int j = 0; j < nz; ++j) {
    for (int i = 0; i < np; ++i) {
      points.emplace_back(static_cast<double>(i) / (np - 1),
                          static_cast<double>(j) / (nz - 1));
    }
  }
  const size_t done = objective->Evaluate(points).size();
  result->message = done < points.size()
                        ? "budget exhausted after " + std::to_string(done) +
                              " of " + std::to_string(points.size()) +
                              " grid points"
                        : "grid of " + std::to_string(np) + " x " +
                              std::to_string(nz) + " points";
  return Status::Ok();
}

}  // namespace kcrig
