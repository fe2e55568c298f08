// The isolability matrix on planned experiments: what a rival's span
// leaves of a candidate's signature, where the experiments cannot tell two
// faults apart and what a return ramp changes.
#include "diagnosis/isolability.h"

#include <cmath>

#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "rt_core/model/channels.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

class IsolabilityTest : public ::testing::Test {
 protected:
  IsolabilityTest() : config_(SourceConfig()) {}

  Experiment Planned(double phi_deg, double z_a, double hold, double back) {
    const ExperimentConfig& e = config_.experiment;
    return PlannedExperiment(
        {phi_deg * kDegree, z_a, e.fmax, e.duration, hold, back}, e);
  }
  Isolability Compute(const std::vector<Experiment>& plan,
                      const std::vector<std::string>& candidates) {
    IsolabilityOptions options;
    options.candidates = candidates;
    Isolability iso;
    const Status status = ComputeIsolability(
        config_.model, plan, config_.experiment.step, options, &iso);
    EXPECT_TRUE(status.ok()) << status.message();
    return iso;
  }
  KcrigConfig config_;
};

TEST_F(IsolabilityTest, ARivalThatSpansACandidateLeavesNothingOfIt) {
  // O1.z is one of O1's three coordinates: O1 reproduces it, not the
  // other way round (what its x and y do; little on these ramps, which
  // mostly see O1's height).
  const Isolability iso =
      Compute({Planned(30, -0.2, 0, 0), Planned(80, -0.4, 0.2, 1)},
              {"model_parameter@O1.z", "model_parameter@O1"});
  ASSERT_EQ(iso.left.rows(), 2);
  EXPECT_TRUE(iso.visible[0] && iso.visible[1]);
  EXPECT_EQ(iso.left(0, 0), 0);
  EXPECT_LT(iso.left(0, 1), 1e-6);
  EXPECT_GT(iso.left(1, 0), 1e-3);
  EXPECT_LT(iso.left(1, 0), 0.2);
  EXPECT_FALSE(iso.Separable(0, 1));
  ASSERT_EQ(iso.Ties().size(), 1u);
}

TEST_F(IsolabilityTest, AReturnRampTellsDampingFromHysteresis) {
  const std::vector<std::string> pair = {"bushing_damping@bushing:V1",
                                         "hysteresis@bushing:V1"};
  // One ramp up: a rate-dependent and a rate-independent loop look alike.
  const Isolability up = Compute({Planned(0, 0, 0, 0)}, pair);
  EXPECT_FALSE(up.Separable(0, 1)) << up.left;
  // Ramps at two rates with holds and returns tell them apart.
  const Isolability loops =
      Compute({Planned(0, 0, 0, 0), Planned(90, -0.3, 0.3, 1.5),
               Planned(45, -0.15, 0, 1)},
              pair);
  EXPECT_TRUE(loops.Separable(0, 1)) << loops.left;
  EXPECT_GT(loops.SmallestSeparation(), up.SmallestSeparation());
}

TEST_F(IsolabilityTest, ALinksTwoEndsTieAndAnUnloadedAxisIsNotSeen) {
  // Ramps in the wheel's plane: nothing loads the actuator's z axis.
  const Isolability iso =
      Compute({Planned(0, 0, 0, 0), Planned(90, -0.3, 0.3, 1.5)},
              {"model_parameter@P", "model_parameter@Q",
               "actuator_lag@actuator:z", "hysteresis@bushing:O1"});
  EXPECT_FALSE(iso.Separable(0, 1)) << iso.left;
  EXPECT_TRUE(iso.Separable(0, 3)) << iso.left;
  EXPECT_FALSE(iso.visible[2]);
  EXPECT_TRUE(std::isnan(iso.left(2, 0)));
  EXPECT_FALSE(iso.Separable(2, 3));
  const auto json = nlohmann::json::parse(IsolabilityToJson(iso));
  EXPECT_TRUE(json["left"][2][0].is_null());
  EXPECT_EQ(json["candidates"].size(), 4u);
  EXPECT_EQ(json["ties"].size(), 1u);
  EXPECT_NE(IsolabilitySummary(iso).find("not seen by these experiments: "
                                         "actuator_lag@actuator:z"),
            std::string::npos)
      << IsolabilitySummary(iso);
}

TEST_F(IsolabilityTest, EveryLibraryCandidateIsComputedWithinItsRange) {
  const Isolability iso =
      Compute({Planned(0, 0, 0, 0), Planned(90, -0.3, 0.3, 1.5)}, {});
  EXPECT_EQ(iso.candidates, IsolabilityCandidates(config_.model));
  for (int i = 0; i < iso.left.rows(); ++i) {
    for (int j = 0; j < iso.left.cols(); ++j) {
      // Undefined where either is not seen.
      if (!iso.visible[i] || !iso.visible[j]) {
        EXPECT_TRUE(std::isnan(iso.left(i, j))) << iso.candidates[i];
        continue;
      }
      EXPECT_GE(iso.left(i, j), -1e-9) << iso.candidates[i];
      EXPECT_LE(iso.left(i, j), 1 + 1e-9) << iso.candidates[i];
    }
  }
}

TEST_F(IsolabilityTest, BadInputIsAnErrorNamingIt) {
  IsolabilityOptions options;
  options.candidates = {"hysteresis@bushing:X9"};
  Isolability iso;
  Status status = ComputeIsolability(config_.model, {Planned(0, 0, 0, 0)},
                                     config_.experiment.step, options, &iso);
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.message().find("X9"), std::string::npos) << status.message();
  options.candidates = {};
  status = ComputeIsolability(config_.model, {}, config_.experiment.step,
                              options, &iso);
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.message().find("no experiment"), std::string::npos);
}

}  // namespace
}  // namespace kcrig
