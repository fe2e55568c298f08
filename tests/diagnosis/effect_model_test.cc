// Candidate models of the diagnosis: the fit recovers an effect's parameters
// from data the software rig's plant made with that effect, with intervals
// that cover the truth, and the nominal candidate is the nominal model.
#include "diagnosis/effect_model.h"

#include <cmath>

#include "gtest/gtest.h"
#include "rt_core/model/channels.h"
#include "tests/support/synthetic.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

class EffectModelTest : public ::testing::Test {
 protected:
  void SetUp() override {
    config_ = SourceConfig();
    ASSERT_TRUE(
        LoadPlantConfig(config_.directory, config_.model, &plant_).ok());
  }
  std::vector<Experiment> TwoExperiments(const char* effect) {
    const std::string text = effect == nullptr ? "" : effect;
    return {PlantExperiment(config_, plant_.model, text,
                            {85 * kDegree, -0.45, 4000, 2.0, 0.3, 1.0}, 3),
            PlantExperiment(config_, plant_.model, text,
                            {20 * kDegree, -0.1, 4000, 1.0, 0.3, 2.0}, 4)};
  }
  KcrigConfig config_;
  PlantConfig plant_;
};

TEST_F(EffectModelTest, NominalCandidateFitsCleanDataToTheNoise) {
  EffectModel model;
  ASSERT_TRUE(EffectModel::Create(config_.model, {}, 0.1, 10, &model).ok());
  EXPECT_EQ(model.Name(), "nominal");
  EffectFit fit;
  const Status status =
      FitEffectModel(model, TwoExperiments(nullptr), {}, EffectFitOptions(),
                     config_.experiment.step, &fit);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_NEAR(fit.result.sigma_hat, 1.0, 0.05);
  for (int i = 0; i < kNumBushings; ++i) {
    const ParameterEstimate& p = fit.result.parameters[i];
    const double truth = plant_.model.bushings[i].stiffness;
    EXPECT_LT(std::abs(p.value - truth), 4 * p.standard_error) << p.name;
  }
}

struct Case {
  const char* effect;
  const char* parameter;  // one of the fitted parameters
  double truth;
};

class EffectRecoveryTest : public EffectModelTest,
                           public ::testing::WithParamInterface<Case> {};

TEST_P(EffectRecoveryTest, RecoversTheEffectWithinItsInterval) {
  const Case c = GetParam();
  const std::string name(c.effect);
  const std::string effect = name.substr(0, name.find(':'));
  EffectModel model;
  ASSERT_TRUE(
      EffectModel::Create(config_.model, {effect}, 0.1, 10, &model).ok());
  EffectFit fit;
  const Status status =
      FitEffectModel(model, TwoExperiments(c.effect), {}, EffectFitOptions(),
                     config_.experiment.step, &fit);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_NEAR(fit.result.sigma_hat, 1.0, 0.05) << fit.result.termination;
  bool found = false;
  for (const ParameterEstimate& p : fit.result.parameters) {
    if (p.name != effect + "." + c.parameter) continue;
    found = true;
    EXPECT_LT(std::abs(p.value - c.truth), 4 * p.standard_error + 1e-9)
        << p.name << " = " << p.value << " +- " << p.standard_error;
  }
  EXPECT_TRUE(found);
}

INSTANTIATE_TEST_SUITE_P(
    Effects, EffectRecoveryTest,
    ::testing::Values(Case{"bushing_damping:d=1e6", "d", 1e6},
                      Case{"hysteresis:force=300,sigma=4e7", "force", 300},
                      Case{"progressive_stiffness:c3=4e11", "c3", 4e11},
                      Case{"actuator_lag:tau=0.03,dead_time=0.01", "tau", 0.03},
                      Case{"rig_compliance:k=2e7", "compliance", 5e-8},
                      Case{"sensor_offset", "toe", 2e-4}),
    [](const ::testing::TestParamInfo<Case>& info) {
      std::string name(info.param.effect);
      return name.substr(0, name.find(':'));
    });

}  // namespace
}  // namespace kcrig
