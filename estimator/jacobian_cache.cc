#include "estimator/jacobian_cache.h"

#include <algorithm>

namespace kcrig {

bool JacobianCache::Holds(double const* const* parameters,
                          int num_parameters) const {
  if (!filled_ || static_cast<int>(parameters_.size()) != num_parameters) {
    return false;
  }
  for (int i = 0; i < num_parameters; ++i) {
    if (parameters_[i] != parameters[i][0]) return false;
  }
  return true;
}

bool JacobianCache::Evaluate(double const* const* parameters,
                             int num_parameters, int num_residuals,
                             double* residuals, double** jacobians,
                             const Evaluation& evaluate) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!Holds(parameters, num_parameters)) {
    filled_ = false;
    parameters_.clear();
    residuals_.assign(num_residuals, 0.0);
    columns_.assign(num_parameters, std::vector<double>(num_residuals, 0.0));
    std::vector<double*> columns(num_parameters);
    for (int i = 0; i < num_parameters; ++i) columns[i] = columns_[i].data();
    if (!evaluate(residuals_.data(), columns.data())) return false;
    for (int i = 0; i < num_parameters; ++i) {
      parameters_.push_back(parameters[i][0]);
    }
    filled_ = true;
  }
  std::copy(residuals_.begin(), residuals_.end(), residuals);
  for (int i = 0; jacobians != nullptr && i < num_parameters; ++i) {
    if (jacobians[i] != nullptr) {
      std::copy(columns_[i].begin(), columns_[i].end(), jacobians[i]);
    }
  }
  return true;
}

}  // namespace kcrig
