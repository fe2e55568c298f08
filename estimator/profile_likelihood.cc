#include "estimator/profile_likelihood.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "estimator/internal/fit_problem.h"

namespace kcrig {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Where the profile first crosses the threshold going outwards on one side
// (relative offset, signed), interpolating linearly in sqrt(delta_chi2),
// which is linear for a quadratic profile. NaN if it never crosses.
double Crossing(const std::vector<double>& offsets,
                const std::vector<double>& delta_chi2, double threshold) {
  double previous_offset = 0, previous_root = 0;
  for (size_t k = 0; k < offsets.size(); ++k) {
    const double root = std::sqrt(std::max(delta_chi2[k], 0.0));
    if (delta_chi2[k] >= threshold) {
      const double w =
          (std::sqrt(threshold) - previous_root) / (root - previous_root);
      return previous_offset + w * (offsets[k] - previous_offset);
    }
    previous_offset = offsets[k];
    previous_root = root;
  }
  return kNaN;
}

}  // namespace

const char* IdentifiabilityName(Identifiability identifiability) {
  switch (identifiability) {
    case Identifiability::kIdentifiable:
      return "identifiable";
    case Identifiability::kPracticallyNot:
      return "practically non-identifiable";
    case Identifiability::kStructurallyNot:
      return "structurally non-identifiable";
  }
  return "?";
}

Identifiability ClassifyProfile(const std::vector<double>& relative_values,
                                const std::vector<double>& delta_chi2,
                                const ProfileOptions& options) {
  double highest = 0;
  for (double d : delta_chi2) highest = std::max(highest, d);
  if (highest < options.flat_fraction * options.threshold) {
    return Identifiability::kStructurallyNot;
  }
  std::vector<double> below_offsets, below_chi2, above_offsets, above_chi2;
  for (size_t k = 0; k < relative_values.size(); ++k) {
    if (relative_values[k] < 0) {
      below_offsets.push_back(-relative_values[k]);
      below_chi2.push_back(delta_chi2[k]);
    } else if (relative_values[k] > 0) {
      above_offsets.push_back(relative_values[k]);
      above_chi2.push_back(delta_chi2[k]);
    }
  }
  // Outwards order on the lower side.
  std::vector<size_t> order(below_offsets.size());
  for (size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return below_offsets[a] < below_offsets[b];
  });
  std::vector<double> lo_offsets, lo_chi2;
  for (size_t k : order) {
    lo_offsets.push_back(below_offsets[k]);
    lo_chi2.push_back(below_chi2[k]);
  }
  const double lower = Crossing(lo_offsets, lo_chi2, options.threshold);
  const double upper = Crossing(above_offsets, above_chi2, options.threshold);
  if (std::isfinite(lower) && std::isfinite(upper) &&
      lower <= options.practical_half_width &&
      upper <= options.practical_half_width) {
    return Identifiability::kIdentifiable;
  }
  return Identifiability::kPracticallyNot;
}

Status ProfileLikelihood(const SuspensionParameters<double>& nominal,
                         const std::vector<Experiment>& experiments,
                         const EstimatorOptions& options,
                         const EstimationResult& fit, double integrator_step,
                         const ProfileOptions& profile_options,
                         std::vector<ParameterProfile>* profiles) {
  std::vector<int> indices;
  Status status = ResolveParameters(nominal, options.parameters, &indices);
  if (!status.ok()) return status;
  const int n = static_cast<int>(indices.size());
  if (fit.parameters.size() != indices.size()) {
    return Status::Error("profile: the fit does not match the options");
  }
  std::vector<double> estimate(n);
  for (int i = 0; i < n; ++i) {
    estimate[i] = fit.parameters[i].value / fit.parameters[i].nominal;
  }
  status = CheckFitMemory(experiments, options, n);
  if (!status.ok()) return status;
  FitProblem problem(nominal, experiments, options, integrator_step, indices);
  ProgressReporter progress(options.callback);
  LeastSquaresOptions refit = FitOptions(options, "profile likelihood");
  refit.callback = progress.Nested();
  profiles->clear();
  for (int i = 0; i < n; ++i) {
    ParameterProfile profile;
    profile.name = fit.parameters[i].name;
    if (!progress.Report({"profile likelihood of " + profile.name,
                          static_cast<double>(i) / n, i, n})) {
      return Interrupted("profile likelihood");
    }
    // The linearized standard error at the stated sigmas sets the first step,
    // so the first point is about one sigma out.
    const double linear_se =
        std::sqrt(std::pow(10.0, fit.parameters[i].log10_inverse_information)) /
        estimate[i];
    const double first_step =
        std::isfinite(linear_se) && linear_se > 1e-9
            ? std::min(linear_se, profile_options.first_step)
            : profile_options.first_step;
    std::vector<double> relative{0.0};
    std::vector<double> delta{0.0};
    for (int side : {-1, +1}) {
      std::vector<double> scaled = estimate;
      for (double r = first_step;;
           r = std::min(2 * r, profile_options.explored_half_width)) {
        const double value = estimate[i] * (1.0 + side * r);
        if (value < options.lower_scale || value > options.upper_scale) break;
        scaled[i] = value;
        std::vector<bool> fixed(n, false);
        fixed[i] = true;
        LeastSquaresSummary summary;
        status = problem.Minimize(refit, fixed, &scaled, &summary);
        if (progress.aborted()) return Interrupted("profile likelihood");
        if (!status.ok()) break;  // the model fails out there: stop this side
        relative.push_back(side * r);
        delta.push_back(std::max(0.0, 2.0 * (summary.cost - fit.cost)));
        if (delta.back() >= profile_options.threshold ||
            r >= profile_options.explored_half_width) {
          break;
        }
      }
    }
    // Sort by value and convert to physical units.
    std::vector<size_t> order(relative.size());
    for (size_t k = 0; k < order.size(); ++k) order[k] = k;
    std::sort(order.begin(), order.end(),
              [&](size_t a, size_t b) { return relative[a] < relative[b]; });
    std::vector<double> sorted_relative, sorted_delta;
    for (size_t k : order) {
      sorted_relative.push_back(relative[k]);
      sorted_delta.push_back(delta[k]);
      profile.values.push_back(fit.parameters[i].value * (1.0 + relative[k]));
      profile.delta_chi2.push_back(delta[k]);
    }
    profile.identifiability =
        ClassifyProfile(sorted_relative, sorted_delta, profile_options);
    std::vector<double> up_offsets, up_chi2, down_offsets, down_chi2;
    for (size_t k = 0; k < sorted_relative.size(); ++k) {
      if (sorted_relative[k] > 0) {
        up_offsets.push_back(sorted_relative[k]);
        up_chi2.push_back(sorted_delta[k]);
      }
    }
    for (size_t k = sorted_relative.size(); k-- > 0;) {
      if (sorted_relative[k] < 0) {
        down_offsets.push_back(-sorted_relative[k]);
        down_chi2.push_back(sorted_delta[k]);
      }
    }
    const double up = Crossing(up_offsets, up_chi2, profile_options.threshold);
    const double down =
        Crossing(down_offsets, down_chi2, profile_options.threshold);
    profile.lower = fit.parameters[i].value * (1.0 - down);
    profile.upper = fit.parameters[i].value * (1.0 + up);
    profiles->push_back(profile);
  }
  return Status::Ok();
}

}  // namespace kcrig
