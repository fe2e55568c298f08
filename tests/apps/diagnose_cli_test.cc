// `kcrig diagnose` as a user runs it: clean logs are `none`; a strong effect
// is attributed and quantified; logs that cannot be diagnosed together are
// one-line errors that leave no diag.json behind.
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/support/child_process.h"
#include "tests/support/cli_runner.h"
#include "tests/support/edited_config.h"
#include "tests/support/temp_dir_test.h"

namespace kcrig {
namespace {

namespace fs = std::filesystem;

class DiagnoseCliTest : public TempDirTest {
 protected:
  // A log by `kcrig simulate` with sensor noise: a ramp, a short hold and a
  // return ramp.
  std::string Simulate(const std::string& name, const std::string& design,
                       int seed, const std::string& extra = "") {
    const std::string csv = Path(name);
    const CliResult r =
        RunKcrig("simulate --noise --seed " + std::to_string(seed) + " " +
                 design + " " + extra + " --out " + csv);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return csv;
  }
  std::string LogA(const std::string& extra = "") {
    return Simulate("a.csv",
                    "--phi 80 --z -0.4 --duration 1.5 --hold 0.2 --return 1",
                    11, extra);
  }
  std::string LogB(const std::string& extra = "") {
    return Simulate("b.csv",
                    "--phi 20 --z -0.1 --duration 1 --hold 0.2 --return 1.5",
                    12, extra);
  }
  std::string Holdout(const std::string& extra = "") {
    return Simulate("h.csv",
                    "--phi 50 --z -0.25 --duration 2 --hold 0.3 --return 1", 13,
                    extra);
  }
  CliResult Diagnose(const std::string& arguments) {
    return RunKcrig("diagnose " + arguments + " --out " + Path("diag.json"));
  }
  void ExpectCleanFailure(const CliResult& result,
                          const std::string& expected) {
    EXPECT_EQ(result.exit_code, 1) << result.output;
    EXPECT_EQ(CountLines(result.output), 1) << result.output;
    EXPECT_NE(result.output.find(expected), std::string::npos) << result.output;
    EXPECT_FALSE(fs::exists(Path("diag.json")));
  }
  nlohmann::json DiagJson() {
    std::ifstream in(Path("diag.json"));
    return nlohmann::json::parse(in);
  }
};

// Rewrites a CSV without the named columns.
void DropColumns(const std::string& from, const std::string& to,
                 const std::vector<std::string>& names) {
  std::ifstream in(from);
  std::ofstream out(to);
  std::string line;
  std::vector<bool> keep;
  while (std::getline(in, line)) {
    std::stringstream cells(line);
    std::string cell, joined;
    for (size_t c = 0; std::getline(cells, cell, ','); ++c) {
      if (keep.size() <= c) {
        keep.push_back(std::find(names.begin(), names.end(), cell) ==
                       names.end());
      }
      if (keep[c]) joined += (joined.empty() ? "" : ",") + cell;
    }
    out << joined << "\n";
  }
}

TEST_F(DiagnoseCliTest, CleanLogsAreNone) {
  const CliResult r = Diagnose("--log " + LogA() + " --log " + LogB());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("verdict: none"), std::string::npos) << r.output;
  const nlohmann::json diag = DiagJson();
  EXPECT_EQ(diag["verdict"], "none");
  EXPECT_FALSE(diag["gap"]["present"].get<bool>());
  EXPECT_GT(diag["gap"]["chi2_p"].get<double>(), 1e-3);
  EXPECT_EQ(diag["localisation"]["channels"].size(), 6u);
  EXPECT_EQ(diag["localisation"]["stiffness_drift"].size(), 5u);
  EXPECT_FALSE(diag["localisation"]["drift_detected"].get<bool>());
  EXPECT_TRUE(diag["candidates"].empty());
}

// SIGINT stops a long diagnosis (a minute: a 61 s log with a gap, every
// candidate fitted) within a few iterations: exit status 130, one line, no
// diag.json nor a temporary of it.
TEST_F(DiagnoseCliTest, SigintStopsItCleanlyAndWritesNothing) {
  const std::string log = Simulate(
      "long.csv", "--phi 80 --z -0.4 --duration 30 --hold 1 --return 30", 11,
      "--effect rig_compliance:k=2e7");
  ChildProcess diagnose(
      {KCRIG_BINARY, "diagnose", "--log", log, "--out", Path("diag.json")},
      Path("output.txt"));
  std::this_thread::sleep_for(std::chrono::seconds(2));
  diagnose.Signal(SIGINT);
  // Exit 130 and no diag.json: it stopped instead of finishing (no
  // wall-clock bound: under the sanitizers one solver iteration is slow).
  EXPECT_EQ(diagnose.Wait(600), 130) << diagnose.Output();
  EXPECT_EQ(diagnose.Output(),
            "kcrig diagnose: interrupted (SIGINT); nothing written\n");
  for (const fs::directory_entry& entry : fs::directory_iterator(dir_)) {
    const std::string name = entry.path().filename().string();
    EXPECT_TRUE(name == "long.csv" || name == "long.json" ||
                name == "output.txt")
        << name;
  }
}

TEST_F(DiagnoseCliTest, LogsWithDifferentForceChannelsAreRefused) {
  const std::string a = LogA(), b = LogB();
  DropColumns(b, Path("b_noforce.csv"), {"Fx", "Fy", "Fz"});
  fs::copy_file(Path("b.json"), Path("b_noforce.json"));
  ExpectCleanFailure(Diagnose("--log " + a + " --log " + Path("b_noforce.csv")),
                     "different channel sets");
}

TEST_F(DiagnoseCliTest, ALogMissingAChannelIsRefused) {
  const std::string a = LogA(), b = LogB();
  DropColumns(b, Path("b_nocaster.csv"), {"caster"});
  fs::copy_file(Path("b.json"), Path("b_nocaster.json"));
  ExpectCleanFailure(
      Diagnose("--log " + a + " --log " + Path("b_nocaster.csv")),
      "b_nocaster.csv");
}

TEST_F(DiagnoseCliTest, AVeryShortLogIsRefused) {
  const std::string short_log = Simulate("short.csv", "--duration 0.2", 14);
  ExpectCleanFailure(Diagnose("--log " + short_log),
                     "short.csv: 201 observed samples");
}

TEST_F(DiagnoseCliTest, AHoldoutFromAnotherGeometryIsRefused) {
  const std::string other = EditConfig(Path("other_config"), "model.yaml",
                                       "chassis: [-0.051, 0.361, 0.117]",
                                       "chassis: [-0.049, 0.361, 0.117]");
  const std::string holdout = Holdout("--config " + other);
  ExpectCleanFailure(Diagnose("--log " + LogA() + " --log " + LogB() +
                              " --holdout " + holdout),
                     "h.csv: recorded with geometry");
}

// A training log given as the hold-out, itself or a copy, would "confirm"
// a diagnosis with the data it was fitted to: refused, naming both.
TEST_F(DiagnoseCliTest, ATrainingLogAsTheHoldoutIsRefused) {
  const std::string a = LogA(), b = LogB();
  ExpectCleanFailure(Diagnose("--log " + a + " --log " + b + " --holdout " + b),
                     "b.csv: holds the same samples as the training log");
  fs::copy_file(b, Path("b_copy.csv"));
  fs::copy_file(Path("b.json"), Path("b_copy.json"));
  ExpectCleanFailure(Diagnose("--log " + a + " --log " + b + " --holdout " +
                              Path("b_copy.csv")),
                     "b_copy.csv: holds the same samples as the training log");
}

TEST_F(DiagnoseCliTest, UnknownCandidateIsRefused) {
  ExpectCleanFailure(
      Diagnose("--log " + LogA() + " --candidates hysteresis,backlash"),
      "unknown effect 'backlash'");
  ExpectCleanFailure(
      Diagnose("--log " + LogA() + " --candidates model_parameter@c_O1"),
      "'c_O1' is not a model parameter a diagnosis frees");
  // A bad option value is a usage error (exit 2), one line as well.
  const CliResult usage = Diagnose("--log " + LogA() + " --free-parameters -1");
  EXPECT_EQ(usage.exit_code, 2) << usage.output;
  EXPECT_EQ(CountLines(usage.output), 1) << usage.output;
  EXPECT_NE(usage.output.find("--free-parameters"), std::string::npos)
      << usage.output;
}

// `kcrig isolability` before a plan is run, and on logs.
TEST_F(DiagnoseCliTest, IsolabilityOfAPlanAndOfLogs) {
  const std::string out = Path("iso.json");
  const CliResult plan = RunKcrig(
      "isolability --quiet --ramp 0,0 --ramp 90,-0.3,2,0.3,1.5 --out " + out);
  ASSERT_EQ(plan.exit_code, 0) << plan.output;
  EXPECT_NE(plan.output.find("2 experiments; 47 candidates"), std::string::npos)
      << plan.output;
  // The two ends of a link cannot be told apart by these ramps.
  EXPECT_NE(plan.output.find("model_parameter@P ~ model_parameter@Q"),
            std::string::npos)
      << plan.output;
  std::ifstream in(out);
  const nlohmann::json doc = nlohmann::json::parse(in);
  EXPECT_EQ(doc["candidates"].size(), 47u);
  EXPECT_EQ(doc["left"].size(), 47u);
  const CliResult logs = RunKcrig(
      "isolability --quiet --log " + LogA() +
      " --candidates hysteresis@bushing:V1,bushing_damping@bushing:V1");
  ASSERT_EQ(logs.exit_code, 0) << logs.output;
  EXPECT_NE(logs.output.find("1 experiment; 2 candidates"), std::string::npos)
      << logs.output;
}

TEST_F(DiagnoseCliTest, IsolabilityRefusesABadPlanInOneLine) {
  const std::string out = Path("iso.json");
  for (const auto& [arguments, expected] :
       std::vector<std::pair<std::string, std::string>>{
           {"--ramp 10", "--ramp '10': expected PHI_DEG,Z_M"},
           {"--ramp 10,-0.1,,0.3", "'' is not a number"},
           {"--ramp 10,abc", "'abc' is not a number"},
           {"--ramp 10,5", "outside the design bounds"},
           {"--ramp 10,-0.1,0", "the ramp time must be positive"},
           {"--candidates hysteresis@bushing:X9", "X9"},
           {"--log " + Path("missing.csv"), "missing.csv"}}) {
    const CliResult r =
        RunKcrig("isolability --quiet " + arguments + " --out " + out);
    EXPECT_EQ(r.exit_code, 1) << arguments << ": " << r.output;
    EXPECT_EQ(CountLines(r.output), 1) << r.output;
    EXPECT_NE(r.output.find(expected), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(out)) << arguments;
  }
}

// `kcrig design --isolate`: the ramp that tells a plan's tied pair apart.
TEST_F(DiagnoseCliTest, DesignIsolateProposesTheRampThatResolvesATie) {
  const std::string out = Path("isolating.json");
  // One ramp up: damping and hysteresis in V1 tie; a ramp at another rate
  // tells them apart.
  CliResult r = RunKcrig(
      "design --isolate --quiet --ramp 0,0 --candidates "
      "hysteresis@bushing:V1,bushing_damping@bushing:V1 --out " +
      out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("1 experiment in the plan, 1 tie"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("resolves 1 of the 1 ties"), std::string::npos)
      << r.output;
  std::ifstream in(out);
  const nlohmann::json doc = nlohmann::json::parse(in);
  ASSERT_EQ(doc["ties"].size(), 1u);
  EXPECT_EQ(doc["resolved"], 1);
  EXPECT_GE(doc["smallest_separation_after"].get<double>(), 0.2);
  EXPECT_LT(doc["smallest_separation_before"].get<double>(), 0.2);
  EXPECT_NE(doc["run_options"].get<std::string>().find("--fmax 4000"),
            std::string::npos);
  // A plan that already tells them apart: nothing to design.
  r = RunKcrig(
      "design --isolate --quiet --ramp 0,0 --ramp 90,-0.3,2,0.3,1.5 "
      "--ramp 45,-0.15,1,0,1 --candidates "
      "hysteresis@bushing:V1,bushing_damping@bushing:V1");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("nothing to design"), std::string::npos) << r.output;
}

// The two modes' options are not mixed.
TEST_F(DiagnoseCliTest, DesignIsolateRefusesTheCriterionsOptions) {
  const std::string out = Path("isolating.json");
  for (const auto& [arguments, expected] :
       std::vector<std::pair<std::string, std::string>>{
           {"--isolate --criterion A", "drop --criterion"},
           {"--ramp 0,0", "--ramp: only with --isolate"},
           {"--isolate --ramp 0,,1", "--ramp '0,,1': '' is not a number"}}) {
    const CliResult r =
        RunKcrig("design --quiet " + arguments + " --out " + out);
    EXPECT_EQ(r.exit_code, 1) << arguments << ": " << r.output;
    EXPECT_EQ(CountLines(r.output), 1) << r.output;
    EXPECT_NE(r.output.find(expected), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(out)) << arguments;
  }
}

}  // namespace
}  // namespace kcrig
