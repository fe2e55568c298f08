#include "estimator/trajectory_residual.h"

#include <algorithm>
#include <type_traits>
#include <utility>

#include "estimator/internal/sensitivity_plant.h"
#include "rt_core/model/excitation.h"
#include "rt_core/model/simulation.h"

namespace kcrig {
namespace {

// The model's parameters at the scaled values; with Jet scalars, derivative
// slot i carries parameter i (slots beyond the parameters stay zero).
template <typename T>
SuspensionParameters<T> ScaledParameters(
    const SuspensionParameters<double>& nominal,
    const std::vector<int>& indices, double const* const* scaled) {
  SuspensionParameters<T> p = nominal.Cast<T>();
  SuspensionParameters<double> nominal_copy = nominal;
  const std::vector<NamedParameter<double>> nominal_list =
      ListParameters(&nominal_copy);
  const std::vector<NamedParameter<T>> list = ListParameters(&p);
  for (size_t i = 0; i < indices.size(); ++i) {
    T s(scaled[i][0]);
    if constexpr (!std::is_same_v<T, double>) s.v[i] = 1.0;
    *list[indices[i]].value = *nominal_list[indices[i]].value * s;
  }
  return p;
}

}  // namespace

TrajectoryResidual::TrajectoryResidual(
    const SuspensionParameters<double>* nominal,
    std::vector<int> parameter_indices, std::vector<int> channels,
    const Experiment* experiment, double integrator_step)
    : nominal_(nominal),
      parameter_indices_(std::move(parameter_indices)),
      channels_(std::move(channels)),
      experiment_(experiment),
      integrator_step_(integrator_step) {
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
  // Sensitivities by the tangent-linear step (exactly the Jet reference's).
  using Model = std::conditional_t<std::is_same_v<T, double>,
                                   SuspensionModel<T>, TangentLinearModel<T>>;
  const Model model(
      ScaledParameters<T>(*nominal_, parameter_indices_, parameters));
  const SampledLoad<T> load{
      &experiment_->forces, experiment_->sample_period, T(experiment_->z_a),
      experiment_->sample_period * (experiment_->forces.size() - 1)};
  SimulationOptions options;
  options.step = integrator_step_;
  options.steps_per_sample = experiment_->steps_per_sample;
  // The residuals are filled as the samples come: a long log's trajectory
  // with sensitivities is never held whole.
  size_t j = 0;
  int row = 0;
  auto fill = [&](const TrajectorySample<T>& sample) {
    if (j >= experiment_->measured.size()) {  // refused below
      ++j;
      return;
    }
    const bool seen = Observed(*experiment_, j);
    for (int k : channels_) {
      // An unobserved sample: zero residual, zero sensitivity.
      const double inverse_sigma = seen ? 1.0 / experiment_->sigma(k) : 0.0;
      const T& x = sample.y(k);
      residuals[row] =
          seen ? (ValueOf(x) - experiment_->measured[j](k)) * inverse_sigma
               : 0.0;
      if constexpr (!std::is_same_v<T, double>) {
        for (size_t d = 0; d < parameter_indices_.size(); ++d) {
          jacobians[d][row] = x.v[d] * inverse_sigma;
        }
      }
      ++row;
    }
    ++j;
  };
  return VisitTrajectory(model, load, options, fill).ok() &&
         j == experiment_->measured.size();
}

bool TrajectoryResidual::Evaluate(double const* const* parameters,
                                  double* residuals, double** jacobians) const {
  if (jacobians == nullptr) {
    return SimulateAndFill<double>(parameters, residuals, nullptr);
  }
  // One tangent-linear trajectory carries every direction; its cost hardly
  // grows with their number, so one Jet size serves every count (each size
  // is a whole tangent-linear model to compile: minutes under the
  // sanitizers).
  static_assert(SensitivityJet::DIMENSION == kMaxEstimatedParameters);
  return cache_.Evaluate(
      parameters, static_cast<int>(parameter_indices_.size()), num_residuals(),
      residuals, jacobians, [&](double* all_residuals, double** columns) {
        return SimulateAndFill<SensitivityJet>(parameters, all_residuals,
                                               columns);
      });
}

}  // namespace kcrig
