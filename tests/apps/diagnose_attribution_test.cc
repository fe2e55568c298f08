// `kcrig diagnose` end to end on logs of the software rig's plant (label
// ci-heavy: a few full diagnoses): a strong effect is attributed and
// quantified; two effects that slow ramps cannot tell apart are reported as
// ambiguous with a discriminating experiment, and running that experiment
// settles the verdict.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/support/cli_runner.h"
#include "tests/support/temp_dir_test.h"

namespace kcrig {
namespace {

class DiagnoseAttributionTest : public TempDirTest {
 protected:
  std::string Simulate(const std::string& name, const std::string& design,
                       int seed, const std::string& truth) {
    const std::string csv = Path(name);
    const CliResult r =
        RunKcrig("simulate --noise --seed " + std::to_string(seed) + " " +
                 design + " " + truth + " --out " + csv);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return csv;
  }
  nlohmann::json Diagnose(const std::string& arguments) {
    const CliResult r =
        RunKcrig("diagnose " + arguments + " --out " + Path("diag.json"));
    EXPECT_EQ(r.exit_code, 0) << r.output;
    std::printf("%s", r.output.c_str());
    std::ifstream in(Path("diag.json"));
    return nlohmann::json::parse(in);
  }
};

TEST_F(DiagnoseAttributionTest, AttributesAndQuantifiesRigCompliance) {
  const std::string truth =
      "--effect rig_compliance:k=2e7 --set c_O1=3.7e6 --set c_P=4.2e6";
  const std::string a = Simulate(
      "a.csv", "--phi 80 --z -0.4 --duration 1.5 --hold 0.2 --return 1", 1,
      truth);
  const std::string b = Simulate(
      "b.csv", "--phi 20 --z -0.1 --duration 1 --hold 0.2 --return 1.5", 2,
      truth);
  const std::string h =
      Simulate("h.csv", "--phi 50 --z -0.25 --duration 2 --hold 0.3 --return 1",
               3, truth);
  const nlohmann::json diag =
      Diagnose("--log " + a + " --log " + b + " --holdout " + h);
  EXPECT_EQ(diag["verdict"], "rig_compliance");
  EXPECT_EQ(diag["confidence"], "high");
  EXPECT_EQ(diag["scoring"], "holdout");
  EXPECT_TRUE(diag["gap"]["present"].get<bool>());
  // The six effects, and at most three model parameters by screening.
  EXPECT_GE(diag["candidates"].size(), 6u);
  EXPECT_LE(diag["candidates"].size(), 9u);
  EXPECT_FALSE(diag["parameter_screening"].empty());
  const nlohmann::json& q = diag["quantification"];
  EXPECT_GE(q["gap_closed"].get<double>(), 0.9);
  for (const char* channel : {"x", "y", "z"}) {
    EXPECT_LT(q["rms_after"][channel].get<double>(),
              q["rms_before"][channel].get<double>())
        << channel;
    // Back at the sensor noise (0.02 mm).
    EXPECT_LT(q["rms_after"][channel].get<double>(), 2.2e-5) << channel;
  }
  ASSERT_EQ(q["effect_parameters"].size(), 1u);
  const nlohmann::json& compliance = q["effect_parameters"][0];
  EXPECT_LT(compliance["ci95"][0].get<double>(), 5e-8);
  EXPECT_GT(compliance["ci95"][1].get<double>(), 5e-8);
  // The stiffnesses after are the truth; before, the mounts' give had
  // biased them.
  const double truth_values[5] = {3.7e6, 4e6, 4e6, 4e6, 4.2e6};
  double largest_bias = 0;
  for (int i = 0; i < 5; ++i) {
    const nlohmann::json& s = q["stiffness"][i];
    EXPECT_LT(std::abs(s["after"].get<double>() - truth_values[i]),
              4 * s["after_standard_error"].get<double>())
        << s;
    largest_bias = std::max(largest_bias, std::abs(s["bias"].get<double>()));
  }
  EXPECT_GT(largest_bias, 1e4);
}

TEST_F(DiagnoseAttributionTest, AmbiguityIsSettledByTheDiscriminatingDesign) {
  // Slow up-ramps in nearly one direction: a little bushing damping looks
  // like a little hysteresis.
  const std::string truth = "--effect bushing_damping:d=1.2e5";
  const std::string a =
      Simulate("a.csv", "--phi 80 --z -0.4 --duration 4", 1, truth);
  const std::string b =
      Simulate("b.csv", "--phi 75 --z -0.35 --duration 4", 2, truth);
  const std::string h =
      Simulate("h.csv", "--phi 70 --z -0.4 --duration 4", 3, truth);
  const std::string candidates =
      " --candidates bushing_damping,actuator_lag,hysteresis";
  const nlohmann::json first =
      Diagnose("--log " + a + " --log " + b + " --holdout " + h + candidates);
  EXPECT_EQ(first["verdict"], "unexplained");
  ASSERT_TRUE(first.contains("discriminating_design")) << first.dump(1);
  const nlohmann::json& design = first["discriminating_design"];
  const std::vector<std::string> pair = design["discriminates"];
  EXPECT_TRUE(
      (pair == std::vector<std::string>{"bushing_damping", "hysteresis"} ||
       pair == std::vector<std::string>{"hysteresis", "bushing_damping"}))
      << design;
  // The design's predicted difference is far beyond what the data had.
  EXPECT_GT(design["divergence"].get<double>(), 1e3);

  // Run the proposed experiment on the same rig and diagnose again.
  const std::string c =
      Simulate("c.csv", design["run_options"].get<std::string>(), 4, truth);
  const nlohmann::json second =
      Diagnose("--log " + a + " --log " + b + " --log " + c + " --holdout " +
               h + candidates);
  EXPECT_EQ(second["verdict"], "bushing_damping");
}

// An error outside the library (V1 moved 3.1 mm, roughly along its own
// link: the full blind tier's case 31) that sensor_offset's common scale and
// shifted stiffnesses mimic to a hold-out chi-square at the noise. What is
// left is correlated, so the attribution may not claim high confidence.
TEST_F(DiagnoseAttributionTest,
       AMimickedGeometryErrorIsNotCalledWithHighConfidence) {
  const std::string truth =
      "--set c_O1=4272017.9 --set c_O2=3864543.26 --set c_V1=3747356.88 "
      "--set c_V2=3962762.81 --set c_P=3603134.54 --set V1.x=0.227104532";
  const std::string a = Simulate(
      "a.csv",
      "--phi 1.32 --z -0.3407 --duration 1.778 --hold 0.142 --return 0.729", 11,
      truth);
  const std::string b = Simulate(
      "b.csv",
      "--phi 71.923 --z -0.2818 --duration 1.535 --hold 0.105 --return 1.204",
      12, truth);
  const std::string h = Simulate(
      "h.csv",
      "--phi 9.129 --z -0.2821 --duration 2.255 --hold 0.157 --return 1.009",
      13, truth);
  const nlohmann::json diag =
      Diagnose("--quiet --log " + a + " --log " + b + " --holdout " + h);
  const std::string verdict = diag["verdict"];
  if (verdict != "none" && verdict != "unexplained") {
    EXPECT_EQ(diag["confidence"], "low") << verdict;
  }
  // The mimic reaches the noise in chi-square but not in whiteness.
  for (const nlohmann::json& c : diag["candidates"]) {
    if (c["model"] != "sensor_offset") continue;
    EXPECT_LT(c["score"].get<double>(), 1.05);
    EXPECT_LT(c["ljung_box_p"].get<double>(), 1e-3);
  }
}

}  // namespace
}  // namespace kcrig
