// `kcrig design` and `kcrig campaign` as a user runs them: the Table-1-style
// comparison, design.json, the campaign's folder and summary, and clear
// one-line errors that leave no output file.
#include <filesystem>
#include <fstream>
#include <string>

#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/support/cli_runner.h"
#include "tests/support/temp_dir_test.h"

namespace kcrig {
namespace {

namespace fs = std::filesystem;

class DesignCampaignCliTest : public TempDirTest {
 protected:
  // `kcrig design` with `options`, writing design.json, and what it wrote.
  CliResult RunDesign(const std::string& options) const {
    return RunKcrig("design " + options + " --out " + Path("design.json"));
  }
  nlohmann::json DesignJson() const {
    return nlohmann::json::parse(std::ifstream(Path("design.json")));
  }
  void ExpectCleanFailure(const std::string& arguments,
                          const std::string& expected) {
    const CliResult r = RunKcrig(arguments + " --out " + Path("design.json"));
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_EQ(CountLines(r.output), 1) << r.output;
    EXPECT_NE(r.output.find(expected), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(Path("design.json")));
  }
};

TEST_F(DesignCampaignCliTest, OptimizerComparisonPrintsTableOneColumns) {
  const CliResult r =
      RunDesign("--criterion D --optimizer kriging,nlopt:bobyqa --budget 40");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* column : {"criterion", "Phi(v0)", "algorithm", "Phi(v*)",
                             "nEv", "wall [s]", "phi [deg]", "z_a [m]"}) {
    EXPECT_NE(r.output.find(column), std::string::npos) << column;
  }
  EXPECT_NE(r.output.find("kriging"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("nlopt:bobyqa"), std::string::npos) << r.output;
  const nlohmann::json doc = DesignJson();
  EXPECT_EQ(doc["criterion"], "D");
  ASSERT_EQ(doc["runs"].size(), 2u);
  const double initial = doc["initial"]["value"];
  const double optimal = doc["optimal"]["value"];
  EXPECT_LT(optimal, initial);
  EXPECT_LE(doc["evaluations"].get<int>(), 40);
  EXPECT_GE(doc["optimal"]["phi_deg"].get<double>(), 0.0);
  EXPECT_LE(doc["optimal"]["phi_deg"].get<double>(), 90.0);
  EXPECT_EQ(doc["runs"][0]["evaluated"].size(),
            doc["runs"][0]["evaluations"].get<size_t>());
}

// The gradient-based and derivative-free NLopt searches on a small budget:
// their callbacks and the stop at the budget (the comparison above, which
// checks the optimum, is numbers: Release only in CI).
TEST_F(DesignCampaignCliTest, NloptSearchesStopAtTheBudget) {
  const CliResult r = RunDesign(
      "--criterion A --optimizer nlopt:bobyqa,nlopt:slsqp,nlopt:mma "
      "--budget 6");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json doc = DesignJson();
  ASSERT_EQ(doc["runs"].size(), 3u);
  for (const nlohmann::json& run : doc["runs"]) {
    EXPECT_LE(run["evaluations"].get<int>(), 6) << run.dump();
    EXPECT_EQ(run["evaluated"].size(), run["evaluations"].get<size_t>());
  }
  EXPECT_LE(doc["optimal"]["value"].get<double>(),
            doc["initial"]["value"].get<double>());
}

TEST_F(DesignCampaignCliTest, BadInputIsOneLineAndNoFile) {
  ExpectCleanFailure("design --budget 0", "--budget 0");
  ExpectCleanFailure("design --criterion Q", "--criterion Q");
  ExpectCleanFailure("design --optimizer simplex", "--optimizer simplex");
  ExpectCleanFailure("design --start-phi 120", "outside the bounds");
  ExpectCleanFailure("design --estimate " + Path("missing.json"),
                     "cannot open");
  std::ofstream(Path("bad.json")) << "{\"format\": \"kcrig estimate 1\"}";
  ExpectCleanFailure("design --estimate " + Path("bad.json"), "parameters");
  ExpectCleanFailure("design --augment", "--augment");
  ExpectCleanFailure("design --kriging-trend cubic", "--kriging-trend cubic");
  // Inverted design bounds in the config.
  const fs::path config = dir_ / "config";
  fs::copy(KCRIG_TEST_CONFIG_DIR, config);
  std::ifstream in(config / "experiment.yaml");
  std::string text((std::istreambuf_iterator<char>(in)), {});
  text.replace(text.find("[-0.5, 0.0]"), 11, "[0.0, -0.5]");
  std::ofstream(config / "experiment.yaml") << text;
  ExpectCleanFailure("design --config " + config.string(), "z_a");
}

TEST_F(DesignCampaignCliTest, KrigingWithALinearTrendAndNoExpectedImprovement) {
  const CliResult r = RunKcrig(
      "design --optimizer kriging --kriging-trend linear "
      "--no-expected-improvement --budget 30 --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("optimal design"), std::string::npos) << r.output;
}

TEST_F(DesignCampaignCliTest, CampaignWritesEveryIterationAndNarrowsIntervals) {
  const CliResult r = RunKcrig(
      "campaign --iterations 1 --budget 20 --quiet --no-report --out " +
      Path("campaign"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("campaign summary"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("next experiment"), std::string::npos) << r.output;
  for (const char* file :
       {"iteration_0/run.csv", "iteration_0/run.json", "iteration_0/est.json",
        "iteration_0/design.json", "iteration_1/run.csv",
        "iteration_1/est.json", "campaign.json"}) {
    EXPECT_TRUE(fs::exists(dir_ / "campaign" / file)) << file;
  }
  const nlohmann::json doc =
      nlohmann::json::parse(std::ifstream(Path("campaign/campaign.json")));
  ASSERT_EQ(doc["iterations"].size(), 2u);
  // plant.yaml's truth lies in the final intervals, which are narrower than
  // the first ones.
  const double truth[] = {3.6e6, 4.4e6, 3.9e6, 4.25e6, 3.75e6};
  for (int i = 0; i < 5; ++i) {
    const nlohmann::json& first = doc["iterations"][0]["parameters"][i];
    const nlohmann::json& last = doc["iterations"][1]["parameters"][i];
    const double lo = last["ci95"][0], hi = last["ci95"][1];
    EXPECT_LT(lo, truth[i]) << last["name"];
    EXPECT_GT(hi, truth[i]) << last["name"];
    EXPECT_LT(hi - lo,
              first["ci95"][1].get<double>() - first["ci95"][0].get<double>())
        << last["name"];
  }
  // The plant is the model: every check passes and nothing is diagnosed.
  for (const nlohmann::json& it : doc["iterations"]) {
    EXPECT_EQ(it["model"], "nominal");
    EXPECT_EQ(it["adequacy"]["verdict"], "adequate") << it["adequacy"];
    EXPECT_EQ(it["check"], "ok");
    EXPECT_TRUE(it["diagnosis"].is_null());
  }
  EXPECT_TRUE(doc["iterations"][0]["prediction"].is_null());
  EXPECT_EQ(doc["iterations"][1]["prediction"]["verdict"], "adequate");
  EXPECT_LT(doc["iterations"][1]["consistency"]["max_z"].get<double>(), 4);
  EXPECT_EQ(r.output.find("not to be trusted"), std::string::npos) << r.output;
}

TEST_F(DesignCampaignCliTest, PlantEffectErrorsAreOneLine) {
  for (const char* options :
       {"--plant-effect wobble", "--plant-effect rig_compliance:k=-1",
        "--plant-effect rig_compliance --rig modbus-tcp://127.0.0.1:1",
        "--plant-set k_spring", "--plant-set wobble=1", "--plant-set mass=-3",
        "--plant-set k_spring=nan",
        "--plant-set k_spring=1e5 --rig modbus-tcp://127.0.0.1:1"}) {
    const CliResult r = RunKcrig(std::string("campaign ") + options +
                                 " --out " + Path("campaign"));
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_EQ(CountLines(r.output), 1) << r.output;
    const std::string option = std::string(options).substr(0, 11);
    EXPECT_NE(r.output.find(option), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(Path("campaign"))) << options;
  }
}

TEST_F(DesignCampaignCliTest, CampaignBadOptionsAreOneLineBeforeAnything) {
  for (const char* options :
       {"--optimizer simplex", "--budget 0", "--target-halfwidth -1",
        "--iterations -1", "--criterion Q"}) {
    const CliResult r = RunKcrig(std::string("campaign ") + options +
                                 " --out " + Path("campaign"));
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_EQ(CountLines(r.output), 1) << r.output;
    EXPECT_FALSE(fs::exists(Path("campaign"))) << options;
  }
}

TEST_F(DesignCampaignCliTest, CampaignRejectsARigItCannotReachBeforeAnyOutput) {
  const CliResult r =
      RunKcrig("campaign --rig can:nocan7 --out " + Path("campaign"));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_EQ(CountLines(r.output), 1) << r.output;
  EXPECT_NE(r.output.find("can:nocan7: "), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(Path("campaign")));
}

}  // namespace
}  // namespace kcrig
