// The diagnosis names the component: a bushing effect in one bushing is
// placed there, a fixture's compliance on its axes, a sensor error on its
// channel (diagnosis.h: place_components). Long enough logs to tell a
// rate-independent loop from damping: too slow for the sanitizers' CI tier
// (label ci-heavy).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "Eigen/Cholesky"
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

// A plant of parameters `truth` with `effects` diagnosed from the blind
// tiers' three ramps (noise seeds first_seed, + 1, + 2).
DiagnosisResult DiagnosedPlant(const KcrigConfig& config,
                               const SuspensionParameters<double>& truth,
                               const PlantEffects& effects,
                               std::uint64_t first_seed) {
  auto log = [&](double phi, double z_a, std::uint64_t seed) {
    return PlantExperiment(config, truth, effects,
                           {phi * kDegree, z_a, 4000, 2.0, 0.3, 1.7}, seed);
  };
  DiagnosisResult r;
  const Status status = Diagnose(
      config.model, {log(85, -0.45, first_seed), log(20, -0.1, first_seed + 1)},
      {log(50, -0.3, first_seed + 2)}, DiagnosisOptions(),
      config.experiment.step, &r);
  EXPECT_TRUE(status.ok()) << status.message();
  std::printf("  verdict %s (%s): %s\n", r.verdict.c_str(), r.model.c_str(),
              r.reason.c_str());
  return r;
}

// The estimate of `name` in the verdict's model; fails the test without it.
ParameterEstimate ChosenParameter(const DiagnosisResult& r,
                                  const std::string& name) {
  for (const CandidateScore& s : r.ranking) {
    if (s.model != r.model) continue;
    for (const ParameterEstimate& p : s.fit.result.parameters) {
      if (p.name == name) return p;
    }
  }
  ADD_FAILURE() << name << " is not in " << r.model;
  return {};
}

// A fixture that gives in translation and turns under the force's moment:
// the global (translational) form explains it badly; the placement names
// the fixture's axes, the rotations among them, and recovers k_rot.
TEST_F(ComponentDiagnosisTest, ARotatingFixtureIsNamedOnItsAxes) {
  PlantEffects effects;
  ASSERT_TRUE(ParseEffect("rig_compliance:k=2e7,k_rot=3e5,at=fixture:x+"
                          "fixture:y+fixture:z+fixture:rx+fixture:ry",
                          &effects)
                  .ok());
  const DiagnosisResult r = DiagnosedPlant(config_, config_.model, effects, 21);
  EXPECT_EQ(r.verdict, "rig_compliance") << r.reason;
  EXPECT_EQ(r.confidence, "high");
  for (const std::string& c : r.components) {
    EXPECT_EQ(c.rfind("fixture:", 0), 0u) << c;
  }
  for (const char* axis :
       {"fixture:x", "fixture:y", "fixture:rx", "fixture:ry"}) {
    EXPECT_NE(std::find(r.components.begin(), r.components.end(), axis),
              r.components.end())
        << axis;
  }
  const ParameterEstimate p =
      ChosenParameter(r, "rig_compliance.rotational_compliance");
  EXPECT_LE(p.ci95_low, 1 / 3e5);
  EXPECT_GE(p.ci95_high, 1 / 3e5);
}

// One actuator's lag (the lateral one): named on its axis, with its time
// constant, where the lag of every actuator explains it badly.
TEST_F(ComponentDiagnosisTest, OneActuatorsLagIsNamedOnItsAxis) {
  PlantEffects effects;
  ASSERT_TRUE(ParseEffect("actuator_lag:tau=0.03,dead_time=0.005,at=actuator:y",
                          &effects)
                  .ok());
  const DiagnosisResult r = DiagnosedPlant(config_, config_.model, effects, 21);
  EXPECT_EQ(r.verdict, "actuator_lag") << r.reason;
  EXPECT_EQ(r.model, "actuator_lag@actuator:y");
  EXPECT_EQ(r.components, std::vector<std::string>{"actuator:y"});
  const ParameterEstimate tau = ChosenParameter(r, "actuator_lag.tau");
  EXPECT_LT(std::abs(tau.value - 0.03), 4 * tau.standard_error + 0.003);
}

// One sensor channel's gain and a coupling from another channel of its
// kind: named on that channel alone, the gain inside its interval.
TEST_F(ComponentDiagnosisTest, OneSensorsGainIsNamedOnItsChannel) {
  PlantEffects effects;
  effects.sensor_offset.enabled = true;
  effects.sensor_offset.offset.setZero();
  effects.sensor_offset.scale = 1;
  effects.sensor_offset.mixing(4, 4) = 0.04;  // camber reads 4 % high
  effects.sensor_offset.mixing(4, 5) = 0.03;  // and sees caster
  const DiagnosisResult r = DiagnosedPlant(config_, config_.model, effects, 21);
  EXPECT_EQ(r.verdict, "sensor_offset") << r.reason;
  EXPECT_EQ(r.model, "sensor_offset@sensor:camber");
  EXPECT_EQ(r.components, std::vector<std::string>{"sensor:camber"});
  const ParameterEstimate gain =
      ChosenParameter(r, "sensor_offset.gain_camber");
  EXPECT_LE(gain.ci95_low, 0.04);
  EXPECT_GE(gain.ci95_high, 0.04);
}

// Wrong "known" parameters (diagnosis.h: model_parameter_pool): logs of a
// plant whose parameter differs from the configured model.
class WrongParameterTest : public ComponentDiagnosisTest {
 protected:
  DiagnosisResult Diagnosed(const std::string& name, double value) {
    SuspensionParameters<double> truth = config_.model;
    *FindParameter(&truth, name) = value;
    return DiagnosedPlant(config_, truth, PlantEffects(), 11);
  }
};

// A spring rate 27 % above the configured one is named, with its value.
TEST_F(WrongParameterTest, TheSpringRateIsNamedWithItsValue) {
  const DiagnosisResult r = Diagnosed("k_spring", 1.4e5);
  EXPECT_EQ(r.verdict, "model_parameter") << r.reason;
  EXPECT_EQ(r.model, "model_parameter@k_spring");
  EXPECT_EQ(r.components, std::vector<std::string>{"strut:spring"});
  ASSERT_FALSE(r.parameter_leads.empty());
  for (const CandidateScore& s : r.ranking) {
    if (s.model != r.model) continue;
    const ParameterEstimate& k = s.fit.result.parameters.back();
    EXPECT_EQ(k.name, "model_parameter.k_spring");
    EXPECT_LE(k.ci95_low, 1.4e5);
    EXPECT_GE(k.ci95_high, 1.4e5);
  }
  EXPECT_NE(r.reason.find("k_spring is"), std::string::npos) << r.reason;
}

// A hard point 4 mm higher: freed whole and named, its move inside its
// 95 % region, or honestly ambiguous between the two ends of its link (O1
// on the chassis, N1 on the carrier), never another component.
TEST_F(WrongParameterTest, AHardPointIsNamedOrItsLinkIsAmbiguous) {
  const double configured = *FindParameter(config_.model, "O1.z");
  const DiagnosisResult r = Diagnosed("O1.z", configured + 0.004);
  if (r.verdict == "model_parameter") {
    EXPECT_EQ(r.model, "model_parameter@O1");
    EXPECT_EQ(r.components, std::vector<std::string>{"hardpoint:O1"});
    ASSERT_EQ(r.hard_points.size(), 1u);
    const HardPointMove& move = r.hard_points[0];
    ASSERT_TRUE(move.bounded);
    const Eigen::Vector3d error =
        Eigen::Vector3d(0, 0, 0.004) - move.displacement;
    EXPECT_LE(error.dot(move.covariance.ldlt().solve(error)),
              kHardPointRegion95)
        << move.displacement.transpose();
    EXPECT_NE(r.reason.find("hard point O1 sits"), std::string::npos)
        << r.reason;
  } else {
    EXPECT_EQ(r.verdict, "unexplained");
    EXPECT_TRUE(r.hard_points.empty());
    const std::vector<std::string> pair = {r.ambiguous_a, r.ambiguous_b};
    EXPECT_NE(std::find(pair.begin(), pair.end(), "model_parameter@O1"),
              pair.end())
        << r.reason;
    EXPECT_NE(std::find(pair.begin(), pair.end(), "model_parameter@N1"),
              pair.end())
        << r.reason;
    // What each alternative says of its hard point.
    EXPECT_NE(r.reason.find("hard point O1 sits"), std::string::npos)
        << r.reason;
    EXPECT_NE(r.reason.find("hard point N1 sits"), std::string::npos)
        << r.reason;
  }
}

}  // namespace
}  // namespace kcrig
