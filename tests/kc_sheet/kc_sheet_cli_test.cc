// `kcrig kc` as a user runs it: gradients equal to an independent NumPy
// computation, model and rig agreeing on logs without an effect, the
// differing channels flagged with one, the SAE axes, and bad input.
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

namespace fs = std::filesystem;

// Two directions at one height, ramp, hold and return: what a K&C rig
// runs. The plant is integrated at a tenth of the model's step, as a
// continuous rig would be.
constexpr const char* kRamp =
    " --z -0.3 --duration 2 --hold 0.5 --return 2 --plant-step 0.0001 "
    "--noise";

class KcSheetCliTest : public TempDirTest {
 protected:
  void Simulate(const std::string& name, double phi_deg, int seed,
                const std::string& extra = "") {
    const CliResult r = RunKcrig("simulate --phi " + std::to_string(phi_deg) +
                                 kRamp + " --seed " + std::to_string(seed) +
                                 " " + extra + " --out " + Path(name));
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  // kc.json of `logs` (" --log a --log b").
  nlohmann::json Sheet(const std::string& logs, const std::string& extra = "") {
    const CliResult r = RunKcrig("kc" + logs + extra + " --out " +
                                 Path("kc.json") + " --csv " + Path("kc.csv"));
    EXPECT_EQ(r.exit_code, 0) << r.output;
    sheet_output_ = r.output;
    return nlohmann::json::parse(std::ifstream(Path("kc.json")));
  }
  std::string Logs() const {
    return " --log " + Path("a.csv") + " --log " + Path("b.csv");
  }
  void ExpectCleanFailure(const std::string& arguments,
                          const std::string& expected) {
    const CliResult r = RunKcrig("kc" + arguments);
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_EQ(CountLines(r.output), 1) << r.output;
    EXPECT_NE(r.output.find(expected), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(Path("kc.json")));
  }
  std::string sheet_output_;
};

TEST_F(KcSheetCliTest, GradientsEqualAnIndependentNumPyComputation) {
  Simulate("a.csv", 80, 3);
  Simulate("b.csv", 10, 4);
  Sheet(Logs());
  for (const char* log : {"a.csv", "b.csv"}) {
    const CliResult peer = RunCommand("/usr/bin/python3 " KCRIG_TEST_PEERS_DIR
                                      "/kc_gradients_numpy.py " +
                                      Path(log) + " " + Path("kc.csv"));
    EXPECT_EQ(peer.exit_code, 0) << peer.output;
    std::printf("%s: %s", log, peer.output.c_str());
  }
}

// The sheet's z of every figure of every run, and how many exceed `limit`.
int CountBeyond(const nlohmann::json& sheet, double limit, int* figures) {
  int beyond = 0;
  for (const auto& run : sheet["runs"]) {
    for (const auto& channel : run["channels"]) {
      for (const char* figure : {"gradient", "loop_width"}) {
        const double z = channel[figure]["difference_z"];
        ++*figures;
        beyond += std::abs(z) > limit;
      }
    }
  }
  return beyond;
}

TEST_F(KcSheetCliTest, ModelAndRigAgreeWithoutAnEffect) {
  // Five pairs of runs, 120 comparisons: their z are the noise's, so about
  // 5 % beyond 2 and none beyond 4.
  int figures = 0, beyond_two = 0, beyond_four = 0;
  for (int k = 0; k < 5; ++k) {
    Simulate("a.csv", 80 - 5 * k, 10 + 2 * k);
    Simulate("b.csv", 10 + 5 * k, 11 + 2 * k);
    const nlohmann::json sheet = Sheet(Logs());
    int unused = 0;
    beyond_two += CountBeyond(sheet, 2.0, &figures);
    beyond_four += CountBeyond(sheet, 4.0, &unused);
  }
  std::printf("no effect: %d of %d figures beyond 2 se, %d beyond 4 se\n",
              beyond_two, figures, beyond_four);
  EXPECT_EQ(beyond_four, 0);
  EXPECT_LE(beyond_two, 0.12 * figures);
}

TEST_F(KcSheetCliTest, FlagsTheChannelsAnEffectChanges) {
  for (const char* effect : {"hysteresis:force=150", "rig_compliance:k=3e6"}) {
    Simulate("a.csv", 80, 21, std::string("--effect ") + effect);
    Simulate("b.csv", 10, 22, std::string("--effect ") + effect);
    const nlohmann::json sheet = Sheet(Logs());
    EXPECT_FALSE(sheet["differing_channels"].empty()) << effect;
    EXPECT_NE(sheet_output_.find("model and rig differ"), std::string::npos)
        << effect << "\n"
        << sheet_output_;
    std::printf("%s: differing %s\n", effect,
                sheet["differing_channels"].dump().c_str());
  }
}

// A rig log (its phases: tare, lead-in, settle, ramp, ramp-down) from the
// embedded rig with rig compliance: the configured model differs on the
// channels the compliance moves; the campaign's adopted model (its est.json
// with the effect's parameter) agrees.
TEST_F(KcSheetCliTest, TheAdoptedEffectModelAgreesWhereTheNominalDiffers) {
  const CliResult campaign = RunKcrig(
      "campaign --rig sim --iterations 0 --no-report --quiet --plant-effect "
      "rig_compliance:k=3e6 --out " +
      Path("campaign"));
  ASSERT_EQ(campaign.exit_code, 0) << campaign.output;
  const std::string log = " --log " + Path("campaign/iteration_0/run.csv");
  const nlohmann::json nominal = Sheet(log);
  EXPECT_EQ(nominal["model"], "nominal");
  EXPECT_FALSE(nominal["runs"][0]["falling_branch"].get<bool>());
  EXPECT_NE(nominal["differing_channels"], nlohmann::json::array());
  const nlohmann::json adopted =
      Sheet(log, " --estimate " + Path("campaign/iteration_0/est.json"));
  EXPECT_EQ(adopted["model"], "rig_compliance");
  EXPECT_EQ(adopted["differing_channels"], nlohmann::json::array())
      << sheet_output_;
  // The rising branch is the rig log's ramp phase alone: 4 s of 1 kHz
  // cycles.
  EXPECT_EQ(adopted["runs"][0]["channels"][0]["rising"]["samples"], 4000);
}

TEST_F(KcSheetCliTest, SaeAxesFlipYZAndTheRotationsAboutThem) {
  Simulate("a.csv", 80, 3);
  Simulate("b.csv", 10, 4);
  const nlohmann::json iso = Sheet(Logs());
  const nlohmann::json sae = Sheet(Logs(), " --convention sae");
  EXPECT_EQ(sae["convention"], "SAE J670");
  const double flip[6] = {1, -1, -1, -1, 1, -1};
  for (int c = 0; c < 6; ++c) {
    const double a = iso["runs"][0]["channels"][c]["gradient"]["rig"]["value"];
    const double b = sae["runs"][0]["channels"][c]["gradient"]["rig"]["value"];
    EXPECT_DOUBLE_EQ(b, flip[c] * a) << c;
  }
  // Lateral force steer: toe and Fy both flip, the figure keeps its sign;
  // longitudinal force steer: toe flips, Fx does not.
  EXPECT_EQ(iso["named_figures"][0]["name"], "lateral force steer");
  EXPECT_DOUBLE_EQ(iso["named_figures"][0]["rig"].get<double>(),
                   sae["named_figures"][0]["rig"].get<double>());
  EXPECT_EQ(iso["named_figures"][4]["name"], "longitudinal force steer");
  EXPECT_DOUBLE_EQ(iso["named_figures"][4]["rig"].get<double>(),
                   -sae["named_figures"][4]["rig"].get<double>());
  // The compliance matrix: y/Fx flips, y/Fy does not; loop widths follow
  // their channel.
  const auto& iso_wc = iso["compliance"]["wheel_centre"]["matrix"];
  const auto& sae_wc = sae["compliance"]["wheel_centre"]["matrix"];
  EXPECT_DOUBLE_EQ(iso_wc[1][0].get<double>(), -sae_wc[1][0].get<double>());
  EXPECT_DOUBLE_EQ(iso_wc[1][1].get<double>(), sae_wc[1][1].get<double>());
  EXPECT_DOUBLE_EQ(
      iso["runs"][0]["channels"][3]["loop_width"]["rig"]["value"].get<double>(),
      -sae["runs"][0]["channels"][3]["loop_width"]["rig"]["value"]
           .get<double>());
  EXPECT_DOUBLE_EQ(iso["runs"][0]["phi_deg"].get<double>(),
                   -sae["runs"][0]["phi_deg"].get<double>());
}

TEST_F(KcSheetCliTest, BadInputIsOneLineAndWritesNothing) {
  Simulate("a.csv", 80, 3);
  const std::string out = " --out " + Path("kc.json");
  ExpectCleanFailure(" --log " + Path("a.csv") + " --convention iso8855" + out,
                     "--convention");
  ExpectCleanFailure(" --log " + Path("a.csv") + " --out " + Path("a.csv"),
                     "--out");
  ExpectCleanFailure(" --log " + Path("missing.csv") + out, "missing.csv");
  std::ofstream(Path("est.json")) << "{\"format\": \"kcrig estimate 1\"}";
  ExpectCleanFailure(
      " --log " + Path("a.csv") + " --estimate " + Path("est.json") + out,
      "est.json");
  ExpectCleanFailure(" --log " + Path("a.csv") + " --contact-patch-z 0.3" + out,
                     "--contact-patch-z");
}

}  // namespace
}  // namespace kcrig
