// The profile likelihood: classification of profiles, and a short run of the
// whole procedure (the acceptance case with an unloaded link is in
// profile_likelihood_unloaded_test.cc, label ci-heavy).
#include "estimator/profile_likelihood.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "gtest/gtest.h"
#include "tests/support/synthetic.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

TEST(ClassifyProfileTest, FlatProfileIsStructural) {
  const ProfileOptions options;
  EXPECT_EQ(ClassifyProfile({-0.5, -0.1, 0, 0.1, 0.5}, {1e-6, 0, 0, 0, 2e-6},
                            options),
            Identifiability::kStructurallyNot);
}

TEST(ClassifyProfileTest, ClosedNarrowProfileIsIdentifiable) {
  const ProfileOptions options;
  EXPECT_EQ(ClassifyProfile({-0.02, -0.01, 0, 0.01, 0.02},
                            {16, 4.1, 0, 3.9, 15.5}, options),
            Identifiability::kIdentifiable);
}

TEST(ClassifyProfileTest, OneSidedOrWideProfileIsPractical) {
  const ProfileOptions options;
  // Rises on one side only.
  EXPECT_EQ(ClassifyProfile({-0.5, -0.1, 0, 0.01, 0.02}, {0.5, 0.1, 0, 4, 16},
                            options),
            Identifiability::kPracticallyNot);
  // Closes, but only beyond +-19.6 %.
  EXPECT_EQ(ClassifyProfile({-0.4, -0.2, 0, 0.2, 0.4}, {5, 1.5, 0, 1.4, 5.2},
                            options),
            Identifiability::kPracticallyNot);
}

TEST(ProfileLikelihoodTest, ShortExperimentGivesClosedProfiles) {
  const KcrigConfig config = SourceConfig();
  const SyntheticSpec spec{config.experiment.phi,  config.experiment.z_a,
                           config.experiment.fmax, /*duration=*/0.5,
                           /*noise=*/true,         /*seed=*/3};
  const std::vector<Experiment> experiments = {
      SyntheticExperiment(config, config.model, spec)};
  EstimatorOptions options;
  options.parameters = {"c_O1", "c_V2"};
  const std::vector<double> initial = {config.model.bushings[kO1].stiffness,
                                       config.model.bushings[kV2].stiffness};
  EstimationResult fit;
  ASSERT_TRUE(Estimate(config.model, experiments, options, initial,
                       config.experiment.step, &fit)
                  .ok());
  std::vector<ParameterProfile> profiles;
  const Status status =
      ProfileLikelihood(config.model, experiments, options, fit,
                        config.experiment.step, ProfileOptions{}, &profiles);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(profiles.size(), 2u);
  for (size_t i = 0; i < profiles.size(); ++i) {
    const ParameterProfile& p = profiles[i];
    EXPECT_EQ(p.identifiability, Identifiability::kIdentifiable) << p.name;
    // The profile crosses the threshold on both sides around the estimate,
    // and the values come sorted.
    EXPECT_LT(p.lower, fit.parameters[i].value);
    EXPECT_GT(p.upper, fit.parameters[i].value);
    EXPECT_TRUE(std::is_sorted(p.values.begin(), p.values.end()));
    const auto at_estimate =
        std::find(p.values.begin(), p.values.end(), fit.parameters[i].value);
    ASSERT_NE(at_estimate, p.values.end());
    EXPECT_EQ(p.delta_chi2[at_estimate - p.values.begin()], 0.0);
  }
}

}  // namespace
}  // namespace kcrig
