// Acceptance 3 (foundation issue): the Jet-derived sensitivities
// dx(t_j)/dp of a whole trajectory (the exact derivatives of the discrete
// semi-implicit Euler solution) agree with central finite differences of the
// double-precision simulation, for all five bushing stiffnesses and all six
// outputs.
#include <cmath>
#include <cstdio>

#include "ceres/jet.h"
#include "gtest/gtest.h"
#include "rt_core/model/simulation.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

using Jet5 = ceres::Jet<double, kNumBushings>;

std::vector<TrajectorySample<double>> Simulate(
    const SuspensionParameters<double>& parameters,
    const RampExcitation<double>& excitation) {
  std::vector<TrajectorySample<double>> samples;
  EXPECT_TRUE(SimulateTrajectory(SuspensionModel<double>(parameters),
                                 excitation, SimulationOptions{}, &samples)
                  .ok());
  return samples;
}

TEST(SensitivityTest, JetSensitivitiesMatchCentralDifferences) {
  const KcrigConfig config = SourceConfig();
  const RampExcitation<double> excitation =
      PaperInitialExcitation(config.experiment);

  // Derivatives with respect to the scaled parameters s_i = c_i / c_i,nominal
  // (the estimator's variables), all five at once.
  SuspensionParameters<Jet5> jet_parameters = config.model.Cast<Jet5>();
  for (int i = 0; i < kNumBushings; ++i) {
    jet_parameters.bushings[i].stiffness =
        config.model.bushings[i].stiffness * Jet5(1.0, i);
  }
  std::vector<TrajectorySample<Jet5>> jet_samples;
  ASSERT_TRUE(SimulateTrajectory(SuspensionModel<Jet5>(jet_parameters),
                                 excitation.Cast<Jet5>(), SimulationOptions{},
                                 &jet_samples)
                  .ok());

  const double delta = 1e-4;  // relative step in each stiffness
  const char* channels[6] = {"x", "y", "z", "toe", "camber", "caster"};
  double worst = 0;
  std::printf(
      "max relative |dx/ds_jet - dx/ds_fd| per output and parameter:\n");
  std::printf("  %-7s", "");
  for (int i = 0; i < kNumBushings; ++i) {
    std::printf(" %9s", ("c_" + std::string(kBushingChassisNames[i])).c_str());
  }
  std::printf("\n");
  Eigen::Matrix<double, 6, kNumBushings> relative_error;
  for (int i = 0; i < kNumBushings; ++i) {
    SuspensionParameters<double> plus = config.model, minus = config.model;
    plus.bushings[i].stiffness *= 1.0 + delta;
    minus.bushings[i].stiffness *= 1.0 - delta;
    const auto samples_plus = Simulate(plus, excitation);
    const auto samples_minus = Simulate(minus, excitation);
    ASSERT_EQ(samples_plus.size(), jet_samples.size());
    for (int k = 0; k < 6; ++k) {
      double scale = 0, difference = 0;
      for (size_t j = 0; j < jet_samples.size(); ++j) {
        const double exact = jet_samples[j].y(k).v(i);
        const double central =
            (samples_plus[j].y(k) - samples_minus[j].y(k)) / (2 * delta);
        scale = std::max(scale, std::abs(exact));
        difference = std::max(difference, std::abs(exact - central));
      }
      ASSERT_GT(scale, 0.0)
          << channels[k] << " does not depend on parameter " << i;
      relative_error(k, i) = difference / scale;
      worst = std::max(worst, relative_error(k, i));
    }
  }
  for (int k = 0; k < 6; ++k) {
    std::printf("  %-7s", channels[k]);
    for (int i = 0; i < kNumBushings; ++i) {
      std::printf(" %9.2e", relative_error(k, i));
    }
    std::printf("\n");
  }
  EXPECT_LE(worst, 1e-6);
}

}  // namespace
}  // namespace kcrig
