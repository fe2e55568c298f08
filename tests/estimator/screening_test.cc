// Acceptance 4 of the estimator issue: screening ranks a parameter without
// influence last. Link P is unloaded by construction of the excitation (the
// mount is statically determinate, so that holds for any stiffness values),
// which leaves c_P without influence on the objective.
#include "estimator/screening.h"

#include <cmath>
#include <cstdio>

#include "gtest/gtest.h"
#include "tests/support/synthetic.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

ScreeningResult ScreenAt(const KcrigConfig& config, double phi) {
  const SyntheticSpec spec{phi, config.experiment.z_a, config.experiment.fmax,
                           config.experiment.duration};
  const std::vector<Experiment> experiments = {
      SyntheticExperiment(config, config.model, spec)};
  ScreeningResult result;
  const Status status =
      Screen(config.model, experiments, EstimatorOptions{}, ScreeningOptions{},
             config.experiment.step, &result);
  EXPECT_TRUE(status.ok()) << status.message();
  std::printf("  %-6s %12s %12s\n", "param", "mu*", "sigma");
  for (const ScreenedParameter& p : result.ranking) {
    std::printf("  %-6s %12.4g %12.4g %s\n", p.name.c_str(), p.mu_star, p.sigma,
                p.negligible ? "negligible" : "");
  }
  std::printf("  estimable:");
  for (const std::string& name : result.estimable)
    std::printf(" %s", name.c_str());
  std::printf("  (%d evaluations, %.2f s)\n", result.evaluations,
              result.seconds);
  return result;
}

TEST(ScreeningTest, UnloadedLinkRanksLastAndIsNotProposed) {
  const KcrigConfig config = SourceConfig();
  std::printf("link P unloaded:\n");
  const ScreeningResult result =
      ScreenAt(config, DirectionUnloadingLink(config, kP));
  ASSERT_EQ(result.ranking.size(), 5u);
  EXPECT_EQ(result.ranking.back().name, "c_P");
  EXPECT_TRUE(result.ranking.back().negligible);
  for (size_t i = 0; i + 1 < result.ranking.size(); ++i) {
    EXPECT_FALSE(result.ranking[i].negligible) << result.ranking[i].name;
  }
  EXPECT_EQ(result.estimable.size(), 4u);
  for (const std::string& name : result.estimable) EXPECT_NE(name, "c_P");
}

TEST(ScreeningTest, PaperDesignProposesAllFive) {
  const KcrigConfig config = SourceConfig();
  std::printf("paper's initial design:\n");
  const ScreeningResult result = ScreenAt(config, config.experiment.phi);
  for (const ScreenedParameter& p : result.ranking) {
    EXPECT_FALSE(p.negligible) << p.name;
  }
  EXPECT_EQ(result.estimable.size(), 5u);
  EXPECT_TRUE(result.dependent_pairs.empty());
}

}  // namespace
}  // namespace kcrig
