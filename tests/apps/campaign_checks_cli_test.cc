// The campaign's model checks acting, through the real CLI on the embedded
// rig: an unmodelled plant effect adopted after the diagnosis attributes
// it, and a hard-point error (no effect of the library) that stops the
// campaign with its own exit status. Release only (label ci-heavy): each
// runs several fits and a diagnosis.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/support/cli_runner.h"
#include "tests/support/edited_config.h"
#include "tests/support/temp_dir_test.h"

namespace kcrig {
namespace {

namespace fs = std::filesystem;

class CampaignChecksCliTest : public TempDirTest {};

// A plant with a rig compliance the stiffnesses absorb: the first fit is
// inadequate but one log cannot tell the compliance from the stiffnesses;
// the second experiment is mispredicted, the diagnosis attributes it and
// the campaign adopts it, the plant's values within the adopted model's
// intervals.
TEST_F(CampaignChecksCliTest, CampaignAdoptsAnAttributedPlantEffect) {
  const CliResult r = RunKcrig(
      "campaign --iterations 1 --budget 20 --quiet --no-report "
      "--plant-effect rig_compliance:k=2e7 --out " +
      Path("campaign"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("plant effects: rig_compliance:k=2e+07"),
            std::string::npos)
      << r.output;
  const nlohmann::json doc =
      nlohmann::json::parse(std::ifstream(Path("campaign/campaign.json")));
  ASSERT_EQ(doc["iterations"].size(), 2u);
  const nlohmann::json& first = doc["iterations"][0];
  EXPECT_EQ(first["adequacy"]["verdict"], "inadequate") << first;
  EXPECT_EQ(first["diagnosis"]["action"], "undecided") << first;
  EXPECT_EQ(first["model"], "nominal");
  EXPECT_TRUE(fs::exists(dir_ / "campaign" / "iteration_0" / "diag.json"));
  const nlohmann::json& last = doc["iterations"][1];
  EXPECT_EQ(last["prediction"]["verdict"], "inadequate") << last["prediction"];
  EXPECT_EQ(last["diagnosis"]["verdict"], "rig_compliance") << last;
  EXPECT_EQ(last["diagnosis"]["action"], "adopted");
  EXPECT_EQ(last["model"], "rig_compliance");
  EXPECT_EQ(last["adequacy"]["verdict"], "adequate") << last["adequacy"];
  // The checks that led to the adoption stay on record; the adopted model
  // passes, so the final estimates are not flagged.
  EXPECT_NE(last["check"].get<std::string>().find("mispredicted"),
            std::string::npos)
      << last["check"];
  EXPECT_EQ(r.output.find("NOT to be trusted"), std::string::npos) << r.output;
  ASSERT_EQ(last["effect_parameters"].size(), 1u);
  ASSERT_EQ(last["nominal_parameters"].size(), 5u);
  // The plant's stiffnesses and compliance within three standard errors
  // of the adopted model's estimates (one seed: coverage is a statistical
  // test's business); the nominal model's are dozens of them off.
  const double truth[] = {3.6e6, 4.4e6, 3.9e6, 4.25e6, 3.75e6};
  auto z = [](const nlohmann::json& p, double truth) {
    const double half =
        0.5 * (p["ci95"][1].get<double>() - p["ci95"][0].get<double>());
    return (p["value"].get<double>() - truth) / (half / 1.96);
  };
  double worst_nominal = 0;
  for (int i = 0; i < 5; ++i) {
    EXPECT_LT(std::abs(z(last["parameters"][i], truth[i])), 3)
        << last["parameters"][i];
    worst_nominal =
        std::max(worst_nominal, std::abs(z(first["parameters"][i], truth[i])));
  }
  EXPECT_GT(worst_nominal, 20);
  EXPECT_LT(std::abs(z(last["effect_parameters"][0], 1 / 2e7)), 3)
      << last["effect_parameters"];
  EXPECT_NE(r.output.find("adopted effect: rig_compliance.compliance"),
            std::string::npos)
      << r.output;
}

// A hard-point error is no effect of the library: the campaign flags the
// fit, the diagnosis finds nothing that explains it, and the campaign stops
// with its own exit status instead of presenting intervals.
TEST_F(CampaignChecksCliTest, CampaignStopsOnAnUnexplainedGap) {
  const std::string config =
      EditConfig(Path("config"), "plant.yaml", "true_parameters:\n",
                 "true_parameters:\n  O1.z: 0.125\n");
  const CliResult r = RunKcrig("campaign --config " + config +
                               " --iterations 2 --budget 20 --quiet "
                               "--no-report --out " +
                               Path("campaign"));
  ASSERT_EQ(r.exit_code, 5) << r.output;
  EXPECT_NE(r.output.find("the campaign stopped"), std::string::npos)
      << r.output;
  const nlohmann::json doc =
      nlohmann::json::parse(std::ifstream(Path("campaign/campaign.json")));
  // Stopped before the iterations asked for were spent.
  ASSERT_LT(doc["iterations"].size(), 3u);
  const nlohmann::json& last = doc["iterations"].back();
  EXPECT_NE(last["check"], "ok");
  EXPECT_EQ(last["diagnosis"]["verdict"], "unexplained") << last["diagnosis"];
  EXPECT_EQ(last["diagnosis"]["action"], "stopped");
  EXPECT_FALSE(last.contains("next_design"));
}

}  // namespace
}  // namespace kcrig
