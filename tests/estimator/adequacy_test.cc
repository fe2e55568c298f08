// Model adequacy: the chi-square tail, the whiteness test, and the verdict of
// a fit and of a prediction on logs of the software rig's plant with and
// without an unmodelled effect.
#include "estimator/adequacy.h"

#include <cmath>
#include <random>

#include "estimator/estimator.h"
#include "gtest/gtest.h"
#include "rt_core/model/channels.h"
#include "tests/support/synthetic.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

TEST(ChiSquareTest, UpperTailMatchesTables) {
  // 95 % quantiles: chi2(1) 3.841, chi2(10) 18.307, chi2(100) 124.342.
  EXPECT_NEAR(ChiSquareUpperTail(3.841459, 1), 0.05, 1e-6);
  EXPECT_NEAR(ChiSquareUpperTail(18.307038, 10), 0.05, 1e-6);
  EXPECT_NEAR(ChiSquareUpperTail(124.342113, 100), 0.05, 1e-6);
  EXPECT_NEAR(ChiSquareUpperTail(2.0, 2), std::exp(-1.0), 1e-12);
  // Large dof: the median is close to dof (1 - 2/(9 dof))^3.
  const double dof = 24000;
  EXPECT_NEAR(ChiSquareUpperTail(dof * std::pow(1 - 2 / (9 * dof), 3), dof),
              0.5, 1e-3);
  EXPECT_EQ(ChiSquareUpperTail(0, 5), 1.0);
  EXPECT_LT(ChiSquareUpperTail(2 * dof, dof), 1e-300);
}

// Two logs of 3000 samples of weighted residuals: white unit noise, with
// `scale` on every channel and, in `ar_channel` (-1: none), an AR(1)
// series of coefficient 0.5 and unit variance instead.
struct ResidualSet {
  std::vector<Experiment> logs;
  std::vector<std::vector<Vec6<double>>> weighted;
};
ResidualSet Residuals(double scale, int ar_channel, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  ResidualSet set;
  for (int l = 0; l < 2; ++l) {
    Experiment e;
    e.measured.assign(3000, Vec6<double>::Zero());
    set.logs.push_back(e);
    std::vector<Vec6<double>>& w = set.weighted.emplace_back(3000);
    double ar = 0;
    for (Vec6<double>& r : w) {
      for (int k = 0; k < 6; ++k) r(k) = scale * normal(rng);
      ar = 0.5 * ar + std::sqrt(0.75) * normal(rng);
      if (ar_channel >= 0) r(ar_channel) = ar;
    }
  }
  return set;
}

const std::vector<int> kAll = {0, 1, 2, 3, 4, 5};

TEST(AdequacyTest, WhiteNoiseAtTheStatedSigmaIsAdequate) {
  int adequate = 0;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    const ResidualSet set = Residuals(1.0, -1, seed);
    const Adequacy a = AssessAdequacy(set.logs, set.weighted, kAll, 5, {});
    EXPECT_NEAR(a.score, 1.0, 0.03);
    EXPECT_EQ(a.dof, 6 * 6000 - 5);
    adequate += a.adequate;
    if (a.adequate) {
      EXPECT_EQ(a.reason, "");
    }
  }
  // At a significance of 1e-3 per test (two tests), 20 seeds all pass but
  // for a rare false alarm.
  EXPECT_GE(adequate, 19);
}

TEST(AdequacyTest, NoiseFivePercentAboveTheSigmaFailsTheChiSquare) {
  const ResidualSet set = Residuals(1.05, -1, 7);
  const Adequacy a = AssessAdequacy(set.logs, set.weighted, kAll, 5, {});
  EXPECT_FALSE(a.adequate);
  EXPECT_LT(a.p_value, 1e-6);
  EXPECT_NEAR(a.chi_square / a.dof, 1.05 * 1.05, 0.03);
  EXPECT_NE(a.reason.find("beyond the sensor noise (chi-square/dof 1.0"),
            std::string::npos)
      << a.reason;
  EXPECT_EQ(a.reason.find("white"), std::string::npos) << a.reason;
}

TEST(AdequacyTest, CorrelatedResidualOfUnitVarianceFailsWhitenessInItsChannel) {
  const ResidualSet set = Residuals(1.0, 4, 3);
  const Adequacy a = AssessAdequacy(set.logs, set.weighted, kAll, 5, {});
  EXPECT_FALSE(a.adequate);
  EXPECT_GT(a.p_value, 1e-3);  // the size is the noise's
  EXPECT_LT(a.channels[4].whiteness_p, 1e-10);
  EXPECT_GT(a.channels[3].whiteness_p, 1e-3);
  EXPECT_NE(a.reason.find("not white in camber"), std::string::npos)
      << a.reason;
}

TEST(AdequacyTest, OnlyTheGivenChannelsCount) {
  ResidualSet set = Residuals(1.0, -1, 5);
  for (auto& log : set.weighted) {
    for (Vec6<double>& r : log) r(5) *= 3;  // caster far off, not fitted
  }
  const Adequacy a =
      AssessAdequacy(set.logs, set.weighted, {0, 1, 2, 3, 4}, 0, {});
  EXPECT_FALSE(a.channels[5].used);
  EXPECT_EQ(a.dof, 5 * 6000);
  EXPECT_NEAR(a.score, 1.0, 0.03);
}

// The fit of a correct model is adequate; an unmodelled rig compliance the
// stiffnesses absorb on one ramp still leaves a residual beyond the noise
// on two, and a fit to one direction mispredicts another.
class FitAdequacyTest : public ::testing::Test {
 protected:
  void SetUp() override { config_ = SourceConfig(); }
  Experiment Log(const std::string& effect, double phi_deg, double z_a,
                 std::uint64_t seed) {
    return PlantExperiment(config_, config_.model, effect,
                           {phi_deg * kDegree, z_a, 4000, 0.5, 0.1, 0.5}, seed);
  }
  EstimationResult Fit(const std::vector<Experiment>& logs) {
    EstimationResult result;
    std::vector<int> indices;
    const EstimatorOptions options;
    EXPECT_TRUE(
        ResolveParameters(config_.model, options.parameters, &indices).ok());
    const Status status = Estimate(config_.model, logs, options,
                                   ParameterValues(config_.model, indices),
                                   config_.experiment.step, &result);
    EXPECT_TRUE(status.ok()) << status.message();
    return result;
  }
  KcrigConfig config_;
};

TEST_F(FitAdequacyTest, CorrectModelFitsAndPredictsAtTheNoise) {
  const EstimationResult fit =
      Fit({Log("", 80, -0.4, 1), Log("", 20, -0.1, 2)});
  EXPECT_TRUE(fit.adequacy.adequate) << fit.adequacy.reason;
  EXPECT_NEAR(fit.adequacy.score, 1.0, 0.05);
  Adequacy prediction;
  const Status status = PredictExperiments(
      config_.model, {Log("", 50, -0.3, 3)}, EstimatorOptions(), fit,
      config_.experiment.step, &prediction);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_TRUE(prediction.adequate) << prediction.reason;
  EXPECT_EQ(prediction.dof, 6 * 1101);
}

TEST_F(FitAdequacyTest, UnmodelledComplianceIsInadequateOrMispredicted) {
  const std::string effect = "rig_compliance:k=1e7";
  const EstimationResult two =
      Fit({Log(effect, 80, -0.4, 1), Log(effect, 20, -0.1, 2)});
  EXPECT_FALSE(two.adequacy.adequate);
  EXPECT_FALSE(two.adequacy.reason.empty());

  const EstimationResult one = Fit({Log(effect, 80, -0.4, 1)});
  Adequacy prediction;
  const Status status = PredictExperiments(
      config_.model, {Log(effect, 20, -0.1, 3)}, EstimatorOptions(), one,
      config_.experiment.step, &prediction);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_FALSE(prediction.adequate);
  EXPECT_GT(prediction.score, 1.5) << prediction.reason;
}

}  // namespace
}  // namespace kcrig
