// The diagnosis names the component: a bushing effect in one bushing is
// placed there (diagnosis.h: place_components). Long enough logs to tell a
// rate-independent loop from damping: too slow for the sanitizers' CI tier
// (label ci-heavy).
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "diagnosis/diagnosis.h"
#include "gtest/gtest.h"
#include "rt_core/model/channels.h"
#include "tests/support/synthetic.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

class ComponentDiagnosisTest : public ::testing::Test {
 protected:
  void SetUp() override { config_ = SourceConfig(); }
  KcrigConfig config_;
};

// Hysteresis in bushing V1 alone: the effect in all five bushings explains
// it badly, so the diagnosis places it, names the one component and
// recovers the Dahl force.
TEST_F(ComponentDiagnosisTest, AWornBushingIsNamedAsOneComponent) {
  // Ramps at three rates, so that the rate-independent Dahl force is not
  // mistaken for damping.
  const std::string effect = "hysteresis:force=600,at=bushing:V1";
  auto log = [&](double phi, double z_a, double ramp, std::uint64_t seed) {
    return PlantExperiment(config_, config_.model, effect,
                           {phi * kDegree, z_a, 4000, ramp, 0.3, ramp}, seed);
  };
  DiagnosisResult r;
  const Status status =
      Diagnose(config_.model, {log(80, -0.4, 1.0, 11), log(20, -0.1, 0.4, 12)},
               {log(50, -0.3, 0.7, 13)}, DiagnosisOptions(),
               config_.experiment.step, &r);
  for (size_t k = 0; k < 4 && k < r.ranking.size(); ++k) {
    std::printf("  %s closes %.0f %%\n", r.ranking[k].model.c_str(),
                100 * r.ranking[k].gap_closed);
  }
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(r.verdict, "hysteresis") << r.reason;
  EXPECT_EQ(r.model, "hysteresis@bushing:V1") << r.reason;
  EXPECT_EQ(r.components, std::vector<std::string>{"bushing:V1"});
  const CandidateScore* chosen = nullptr;
  for (const CandidateScore& s : r.ranking) {
    if (s.model == r.model) chosen = &s;
  }
  ASSERT_NE(chosen, nullptr);
  EXPECT_GT(chosen->gap_closed, 0.8);
  for (const ParameterEstimate& p : chosen->fit.result.parameters) {
    if (p.name != "hysteresis.force") continue;
    EXPECT_LT(std::abs(p.value - 600), 4 * p.standard_error + 30) << p.value;
  }
}

}  // namespace
}  // namespace kcrig
