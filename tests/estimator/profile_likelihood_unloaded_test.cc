// Acceptance 3 of the estimator issue, profile-likelihood part: the
// unloaded-link set-up is non-identifiable by the profile too, while the
// other four bushings get closed profile intervals close to the linearized
// ones. Label ci-heavy: minutes under the sanitizers.
#include <cmath>
#include <cstdio>

#include "estimator/profile_likelihood.h"
#include "gtest/gtest.h"
#include "tests/support/synthetic.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

void PrintProfiles(const std::vector<ParameterProfile>& profiles) {
  for (const ParameterProfile& p : profiles) {
    std::printf("  %-5s %-30s interval [%.1f, %.1f] N/mm, %zu points\n",
                p.name.c_str(), IdentifiabilityName(p.identifiability),
                p.lower * 1e-3, p.upper * 1e-3, p.values.size());
  }
}

TEST(ProfileLikelihoodTest, UnloadedLinkIsNotIdentifiableByTheProfile) {
  const KcrigConfig config = SourceConfig();
  SyntheticSpec spec{DirectionUnloadingLink(config, kP),
                     config.experiment.z_a,
                     config.experiment.fmax,
                     config.experiment.duration,
                     /*noise=*/true,
                     /*seed=*/11};
  const std::vector<Experiment> experiments = {
      SyntheticExperiment(config, config.model, spec)};
  std::vector<double> initial;
  for (int i = 0; i < kNumBushings; ++i) {
    initial.push_back(config.model.bushings[i].stiffness);
  }
  const EstimatorOptions options;
  EstimationResult fit;
  ASSERT_TRUE(Estimate(config.model, experiments, options, initial,
                       config.experiment.step, &fit)
                  .ok());
  std::vector<ParameterProfile> profiles;
  const Status status =
      ProfileLikelihood(config.model, experiments, options, fit,
                        config.experiment.step, ProfileOptions{}, &profiles);
  ASSERT_TRUE(status.ok()) << status.message();
  std::printf("profiles with link P unloaded:\n");
  PrintProfiles(profiles);
  ASSERT_EQ(profiles.size(), 5u);
  for (const ParameterProfile& p : profiles) {
    if (p.name == "c_P") {
      EXPECT_EQ(p.identifiability, Identifiability::kPracticallyNot);
    } else {
      EXPECT_EQ(p.identifiability, Identifiability::kIdentifiable) << p.name;
      // Close to the linearized interval where the model is nearly linear.
      const ParameterEstimate& e = fit.parameters[&p - profiles.data()];
      EXPECT_NEAR(p.upper - p.lower, e.ci95_high - e.ci95_low,
                  0.1 * (e.ci95_high - e.ci95_low))
          << p.name;
    }
  }
}

}  // namespace
}  // namespace kcrig
