// Acceptance 1 (foundation issue): the semi-implicit Euler converges at
// first order in h towards SUNDIALS CVODE at tight tolerance on the same
// model.
//
// The bushing modes (~70-100 Hz) are stiff and lightly damped. Any free
// ringing in the solution (the paper's ramp starts with a jump in force rate)
// is damped by the method at a rate ~ h omega^2 / 2 (200 1/s at h = 1 ms)
// against ~15 1/s physically, so its error is not yet in the asymptotic
// regime for h = 0.5..4 ms. The order is therefore measured on a K&C load
// cycle that starts C3-smooth and excites no free ringing; the paper's ramp
// is checked for its absolute error at the paper's step.
#include <cmath>
#include <cstdio>
#include <vector>

#include "gtest/gtest.h"
#include "rt_core/model/simulation.h"
#include "tests/support/reference_integrators.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

// Force magnitude Fmax * ((1 - cos(2 pi t / T)) / 2)^2 in the paper's
// initial direction and height: zero force, rate, jerk and snap at t = 0.
struct SmoothLoadCycle {
  double phi, z_a, fmax, duration;
  double EndTime() const { return duration; }
  RigLoad<double> LoadAt(double t) const {
    const double c = 0.5 * (1.0 - std::cos(2.0 * M_PI * t / duration));
    RigLoad<double> load;
    load.force << fmax * c * c * std::cos(phi), fmax * c * c * std::sin(phi), 0;
    load.point << 0, 0, z_a;
    return load;
  }
};

struct ConvergenceTable {
  std::vector<double> steps;
  std::vector<double> errors;  // max over samples and channels, in sigmas
};

// Errors of the semi-implicit Euler against CVODE (rtol 1e-12) for each h,
// in units of the sensor sigma so metres and radians weigh as in the
// estimator.
template <typename Excitation>
ConvergenceTable Measure(const KcrigConfig& config,
                         const Excitation& excitation, const char* title) {
  const SuspensionModel<double> model(config.model);
  Vec6<double> sigma;
  sigma << Vec3<double>::Constant(config.experiment.sigma_position),
      Vec3<double>::Constant(config.experiment.sigma_angle);
  const double sample_period = 4e-3;  // a multiple of every h below
  ModelState<double> initial;
  EXPECT_TRUE(
      SolveStaticEquilibrium(model, excitation.LoadAt(0.0), 50, &initial.y)
          .ok());
  std::vector<double> times;
  for (int j = 1; j * sample_period <= excitation.duration + 1e-12; ++j) {
    times.push_back(j * sample_period);
  }
  CvodeOptions tight;
  tight.relative_tolerance = 1e-12;
  tight.absolute_tolerance_position = 1e-15;
  tight.absolute_tolerance_velocity = 1e-13;
  CvodeResult reference;
  const Status status = IntegrateWithCvode(
      model, [&](double t) { return excitation.LoadAt(t); }, initial, times,
      tight, &reference);
  EXPECT_TRUE(status.ok()) << status.message();

  ConvergenceTable table;
  std::printf("%s\n   h [ms]   max |x - x_cvode| / sigma   observed order\n",
              title);
  for (double h : {4e-3, 2e-3, 1e-3, 0.5e-3}) {
    SimulationOptions options;
    options.step = h;
    options.steps_per_sample = static_cast<int>(std::lround(sample_period / h));
    std::vector<TrajectorySample<double>> samples;
    EXPECT_TRUE(SimulateTrajectory(model, excitation, options, &samples).ok());
    EXPECT_EQ(samples.size(), times.size() + 1);
    double error = 0;
    for (size_t j = 0; j < times.size() && j + 1 < samples.size(); ++j) {
      error = std::max(error, (samples[j + 1].y - reference.y[j])
                                  .cwiseQuotient(sigma)
                                  .cwiseAbs()
                                  .maxCoeff());
    }
    if (table.errors.empty()) {
      std::printf("  %6.2f   %24.6e\n", h * 1e3, error);
    } else {
      std::printf("  %6.2f   %24.6e   %14.3f\n", h * 1e3, error,
                  std::log2(table.errors.back() / error));
    }
    table.steps.push_back(h);
    table.errors.push_back(error);
  }
  std::printf("  CVODE reference: %ld steps, %ld RHS evaluations\n",
              reference.steps, reference.rhs_evaluations);
  return table;
}

// Least-squares slope of log(error) over log(h).
double FittedOrder(const ConvergenceTable& table) {
  const size_t n = table.steps.size();
  double mean_x = 0, mean_y = 0;
  for (size_t i = 0; i < n; ++i) {
    mean_x += std::log(table.steps[i]) / n;
    mean_y += std::log(table.errors[i]) / n;
  }
  double sxy = 0, sxx = 0;
  for (size_t i = 0; i < n; ++i) {
    const double dx = std::log(table.steps[i]) - mean_x;
    sxy += dx * (std::log(table.errors[i]) - mean_y);
    sxx += dx * dx;
  }
  return sxy / sxx;
}

TEST(IntegratorConvergenceTest, FirstOrderAgainstCvodeOnSmoothLoadCycle) {
  const KcrigConfig config = SourceConfig();
  const SmoothLoadCycle cycle{config.experiment.phi, config.experiment.z_a,
                              config.experiment.fmax, 2.0};
  const ConvergenceTable table =
      Measure(config, cycle, "smooth K&C load cycle, T = 2 s:");
  const double order = FittedOrder(table);
  std::printf("  fitted order %.3f\n", order);
  EXPECT_GE(order, 0.8);
  EXPECT_LE(order, 1.2);
}

TEST(IntegratorConvergenceTest, PaperRampErrorStaysBelowSensorNoise) {
  const KcrigConfig config = SourceConfig();
  const ConvergenceTable table =
      Measure(config, PaperInitialExcitation(config.experiment),
              "paper's ramp (phi 85 deg, z_a -0.45 m), start transient "
              "included:");
  std::printf("  fitted order %.3f (pre-asymptotic: see file comment)\n",
              FittedOrder(table));
  // At the paper's h = 1 ms the integration error stays well inside the
  // sensor noise, and it does not grow as h shrinks.
  EXPECT_LT(table.errors[2], 0.5);
  for (size_t i = 1; i < table.errors.size(); ++i) {
    EXPECT_LE(table.errors[i], table.errors[i - 1]);
  }
}

}  // namespace
}  // namespace kcrig
