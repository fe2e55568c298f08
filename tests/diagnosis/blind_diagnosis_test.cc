// Blind test of `kcrig diagnose`, through `kcrig validate` (the same
// generator and scoring a user runs on their configuration): cases drawn
// from a seed — each of the six library effects, none, or a wrong "known"
// parameter (a hard point moved in 3D, or the spring rate), a
// magnitude from small to large, where a bushing effect acts (one bushing
// or all), the rig's true bushings +-10 % off the
// configured ones, the designs of two training logs and one hold-out log,
// the noise — run back to back on the embedded SIL rig (its phases,
// actuator, load cell and memory; the plant stepped ten times finer than
// the model), diagnosed with the truth stripped, and only then scored. The size
// of an effect "in the residual" is the RMS, in noise units, of the nominal
// model's residual on the same training logs without noise.
//
// Acceptance (issues #7, #19): correct verdict for >= 90 % of the effect
// cases whose effect exceeds 3x the noise, and for >= 80 % of the bushing
// effects among them (one case in two in a single bushing) also the right
// component; `none` for >= 95 % of the clean
// ones; a wrong parameter beyond 3x the noise named (model_parameter@ it),
// or one of an ambiguous pair, in >= 80 % and never another model with
// high confidence, its true value inside the 95 % interval in >= 90 % of
// those named (asserted with ten or more; a hard point's move inside its
// 3D region); >= 80 % of the held-out gap closed, or only noise left, for
// the correctly attributed cases. validate prints the confusion
// matrix.
//
// KCRIG_BLIND_CASES and KCRIG_BLIND_SEED are compile definitions: the CI
// tier and the full tier are two builds of this file.
#include <cstdio>
#include <fstream>
#include <string>

#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/support/cli_runner.h"
#include "tests/support/temp_dir_test.h"

namespace kcrig {
namespace {

// The two tiers are two test names for ctest.
#ifdef KCRIG_BLIND_FULL_TIER
#define KCRIG_BLIND_SUITE BlindDiagnosisFullTierTest
#else
#define KCRIG_BLIND_SUITE BlindDiagnosisTest
#endif

class KCRIG_BLIND_SUITE : public TempDirTest {};

void PrintCase(const nlohmann::json& c) {
  const double closed =
      c["gap_closed"].is_number() ? c["gap_closed"].get<double>() : 0.0;
  std::printf("%4d %-22s %6.2f %7.2f  %-36s %-5s %6.0f%%\n",
              c["index"].get<int>(), c["truth"].get<std::string>().c_str(),
              c["magnitude"].get<double>(), c["size_sigma"].get<double>(),
              c["verdict"].get<std::string>().c_str(),
              c["confidence"].get<std::string>().c_str(), 100 * closed);
  std::printf("     truth %s; designs", c["truth_options"].dump().c_str());
  for (const char* kind : {"training", "holdout"}) {
    for (const nlohmann::json& d : c["designs"][kind]) {
      std::printf(" %s [%s]", kind, d.get<std::string>().c_str());
    }
  }
  std::printf("\n");
}

TEST_F(KCRIG_BLIND_SUITE, VerdictsAgainstTheTruth) {
  const std::string out = Path("validate.json");
  const CliResult run =
      RunKcrig("validate --quiet --cases " + std::to_string(KCRIG_BLIND_CASES) +
               " --seed " + std::to_string(KCRIG_BLIND_SEED) + " --out " + out);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  std::ifstream in(out);
  const nlohmann::json doc = nlohmann::json::parse(in);
  int wrong_parameters = 0, confident_misattribution = 0;
  for (const nlohmann::json& c : doc["case_results"]) {
    PrintCase(c);
    if (c["truth"] != "model_parameter" || c["size_sigma"] <= 3) continue;
    ++wrong_parameters;
    confident_misattribution += c["confident_wrong"].get<bool>();
  }
  std::printf("%s", run.output.c_str());

  const nlohmann::json& f = doc["figures"];
  const nlohmann::json& large = f["library_effects_beyond_3_sigma"];
  const nlohmann::json& clean = f["clean"];
  const nlohmann::json& parameters = f["wrong_parameters_beyond_3_sigma"];
  const nlohmann::json& interval = f["true_value_in_95_interval"];
  const nlohmann::json& closed = f["gap_closed_80_percent_when_correct"];
  ASSERT_GT(large["total"], 0);
  ASSERT_GT(clean["total"], 0);
  ASSERT_GT(parameters["total"], 0);
  EXPECT_EQ(parameters["total"], wrong_parameters);
  EXPECT_GE(large["correct"].get<double>(), 0.9 * large["total"].get<int>());
  const nlohmann::json& placed =
      f["bushing_effects_beyond_3_sigma_right_component"];
  ASSERT_GT(placed["total"], 0);
  EXPECT_GE(placed["correct"].get<double>(), 0.8 * placed["total"].get<int>());
  EXPECT_GE(clean["none"].get<double>(), 0.95 * clean["total"].get<int>());
  EXPECT_GE(parameters["named"].get<int>() +
                parameters["one_of_an_ambiguous_pair"].get<int>(),
            0.8 * parameters["total"].get<int>());
  EXPECT_EQ(confident_misattribution, 0);
  if (parameters["named"] >= 10) {
    EXPECT_GE(interval["inside"].get<double>(),
              0.9 * parameters["named"].get<int>());
  }
  EXPECT_EQ(closed["closed"], closed["total"]);
}

}  // namespace
}  // namespace kcrig
