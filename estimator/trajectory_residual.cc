#include "estimator/trajectory_residual.h"

#include <algorithm>
#include <utility>

#include "ceres/jet.h"
#include "rt_core/excitation.h"
#include "rt_core/simulation.h"

namespace kcrig {
namespace {

template <typename T>
SuspensionParameters<T> ScaledParameters(
    const SuspensionParameters<double>& nominal,
    const std::vector<int>& indices, double const* const* scaled,
    bool seed_derivatives) {
  SuspensionParameters<T> p = nominal.Cast<T>();
  SuspensionParameters<double> nominal_copy = nominal;
  const std::vector<NamedParameter<double>> nominal_list =
      ListParameters(&nominal_copy);
  const std::vector<NamedParameter<T>> list = ListParameters(&p);
  for (size_t i = 0; i < indices.size(); ++i) {
    T s(scaled[i][0]);
    if constexpr (!std::is_same_v<T, double>) {
      if (seed_derivatives) s.v[i] = 1.0;
    }
    *list[indices[i]].value = *nominal_list[indices[i]].value * s;
  }
  return p;
}

}  // namespace

TrajectoryResidual::TrajectoryResidual(
    const SuspensionParameters<double>* nominal,
    std::vector<int> parameter_indices, std::vector<int> channels,
    const Experiment* experiment, double integrator_step, double lower_scale,
    double upper_scale)
    : nominal_(nominal),
      parameter_indices_(std::move(parameter_indices)),
      channels_(std::move(channels)),
      experiment_(experiment),
      integrator_step_(integrator_step),
      lower_scale_(lower_scale),
      upper_scale_(upper_scale) {
  for (size_t i = 0; i < parameter_indices_.size(); ++i) {
    mutable_parameter_block_sizes()->push_back(1);
  }
  set_num_residuals(
      static_cast<int>(experiment_->measured.size() * channels_.size()));
}

template <typename T>
bool TrajectoryResidual::SimulateAndFill(double const* const* parameters,
                                         double* residuals,
                                         double** jacobians) const {
  const SuspensionModel<T> model(ScaledParameters<T>(
      *nominal_, parameter_indices_, parameters, /*seed_derivatives=*/true));
  const SampledLoad<T> load{
      &experiment_->forces, experiment_->sample_period, T(experiment_->z_a),
      experiment_->sample_period * (experiment_->forces.size() - 1)};
  SimulationOptions options;
  options.step = integrator_step_;
  options.steps_per_sample = experiment_->steps_per_sample;
  std::vector<TrajectorySample<T>> samples;
  if (!SimulateTrajectory(model, load, options, &samples).ok()) return false;
  const int n = static_cast<int>(parameter_indices_.size());
  int row = 0;
  for (size_t j = 0; j < samples.size(); ++j) {
    for (int k : channels_) {
      const double inverse_sigma = 1.0 / experiment_->sigma(k);
      const T& x = samples[j].y(k);
      residuals[row] =
          (ValueOf(x) - experiment_->measured[j](k)) * inverse_sigma;
      if constexpr (!std::is_same_v<T, double>) {
        for (int i = 0; i < n; ++i) {
          if (jacobians[i] != nullptr) {
            jacobians[i][row] = x.v[i] * inverse_sigma;
          }
        }
      }
      ++row;
    }
  }
  return true;
}

bool TrajectoryResidual::Evaluate(double const* const* parameters,
                                  double* residuals, double** jacobians) const {
  for (size_t i = 0; i < parameter_indices_.size(); ++i) {
    const double s = parameters[i][0];
    if (!(s >= lower_scale_ && s <= upper_scale_)) return false;
  }
  if (jacobians != nullptr) {
    const size_t n = parameter_indices_.size();
    const size_t m = static_cast<size_t>(num_residuals());
    std::lock_guard<std::mutex> lock(cache_mutex_);
    bool cached = cached_parameters_.size() == n;
    for (size_t i = 0; cached && i < n; ++i) {
      cached = cached_parameters_[i] == parameters[i][0];
    }
    if (!cached) {
      // Evaluate into the cache with every column requested.
      cached_residuals_.assign(m, 0.0);
      cached_jacobian_.assign(n, std::vector<double>(m, 0.0));
      std::vector<double*> columns(n);
      for (size_t i = 0; i < n; ++i) columns[i] = cached_jacobian_[i].data();
      bool ok = false;
      double* r = cached_residuals_.data();
      double** c = columns.data();
      // The Jet size follows the number of parameters.
      switch (n) {
        case 1:
          ok = SimulateAndFill<ceres::Jet<double, 1>>(parameters, r, c);
          break;
        case 2:
          ok = SimulateAndFill<ceres::Jet<double, 2>>(parameters, r, c);
          break;
        case 3:
          ok = SimulateAndFill<ceres::Jet<double, 3>>(parameters, r, c);
          break;
        case 4:
          ok = SimulateAndFill<ceres::Jet<double, 4>>(parameters, r, c);
          break;
        case 5:
          ok = SimulateAndFill<ceres::Jet<double, 5>>(parameters, r, c);
          break;
        case 6:
          ok = SimulateAndFill<ceres::Jet<double, 6>>(parameters, r, c);
          break;
        default:
          ok = SimulateAndFill<ceres::Jet<double, kMaxEstimatedParameters>>(
              parameters, r, c);
      }
      if (!ok) {
        cached_parameters_.clear();
        return false;
      }
      cached_parameters_.assign(n, 0.0);
      for (size_t i = 0; i < n; ++i) cached_parameters_[i] = parameters[i][0];
    }
    std::copy(cached_residuals_.begin(), cached_residuals_.end(), residuals);
    for (size_t i = 0; i < n; ++i) {
      if (jacobians[i] != nullptr) {
        std::copy(cached_jacobian_[i].begin(), cached_jacobian_[i].end(),
                  jacobians[i]);
      }
    }
    return true;
  }
  return SimulateAndFill<double>(parameters, residuals, nullptr);
}

}  // namespace kcrig
