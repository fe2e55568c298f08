// Acceptance 2 of the estimator issue, a calibration test of the
// covariance: statistical (200 noisy re-estimations), so it carries the ctest
// label "statistical" besides "ci".
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <thread>

#include "estimator/estimator.h"
#include "gtest/gtest.h"
#include "tests/support/synthetic.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

// Acceptance 2: the 95 % intervals cover the truth in 90-98 % of 200 noise
// seeds for every parameter: a calibration test of the covariance.
TEST(EstimatorTest, IntervalsAreCalibratedOver200Seeds) {
  const KcrigConfig config = SourceConfig();
  const SuspensionParameters<double> truth = DistinctBushingTruth(config.model);
  constexpr int kSeeds = 200;
  std::vector<std::array<bool, kNumBushings>> covered(kSeeds);
  std::vector<double> sigma_hat(kSeeds, 0.0);
  std::atomic<int> next{0};
  std::atomic<int> failures{0};
  auto worker = [&] {
    for (int seed; (seed = next++) < kSeeds;) {
      SyntheticSpec spec{config.experiment.phi, config.experiment.z_a,
                         config.experiment.fmax, config.experiment.duration};
      spec.noise = true;
      spec.seed = 1000 + seed;
      const std::vector<Experiment> experiments = {
          SyntheticExperiment(config, truth, spec)};
      std::vector<double> initial;
      for (int i = 0; i < kNumBushings; ++i) {
        initial.push_back(truth.bushings[i].stiffness * 1.05);
      }
      EstimatorOptions options;
      options.num_threads = 1;
      EstimationResult result;
      if (!Estimate(config.model, experiments, options, initial,
                    config.experiment.step, &result)
               .ok() ||
          !result.converged) {
        ++failures;
        continue;
      }
      sigma_hat[seed] = result.sigma_hat;
      for (int i = 0; i < kNumBushings; ++i) {
        const double t = truth.bushings[i].stiffness;
        covered[seed][i] = result.parameters[i].ci95_low <= t &&
                           t <= result.parameters[i].ci95_high;
      }
    }
  };
  std::thread a(worker), b(worker);
  a.join();
  b.join();
  ASSERT_EQ(failures.load(), 0);
  std::printf("coverage of the 95 %% intervals over %d seeds:\n", kSeeds);
  for (int i = 0; i < kNumBushings; ++i) {
    int hits = 0;
    for (int seed = 0; seed < kSeeds; ++seed) hits += covered[seed][i];
    const double coverage = 100.0 * hits / kSeeds;
    std::printf("  c_%s  %.1f %%\n",
                std::string(kBushingChassisNames[i]).c_str(), coverage);
    EXPECT_GE(coverage, 90.0);
    EXPECT_LE(coverage, 98.0);
  }
  double mean_sigma_hat = 0;
  for (double s : sigma_hat) mean_sigma_hat += s / kSeeds;
  std::printf("  mean sigma_hat %.4f (1 when the stated sigmas are right)\n",
              mean_sigma_hat);
  EXPECT_NEAR(mean_sigma_hat, 1.0, 0.02);
}

}  // namespace
}  // namespace kcrig
