// `kcrig estimate` as a user runs it: on a log written by `kcrig simulate`,
// and on bad input, which must leave no est.json behind.
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/support/child_process.h"
#include "tests/support/cli_runner.h"
#include "tests/support/temp_dir_test.h"

namespace kcrig {
namespace {

namespace fs = std::filesystem;

class EstimateCliTest : public TempDirTest {
 protected:
  void Simulate(const std::string& extra) {
    const CliResult r = RunKcrig("simulate --duration 1 " + extra + " --out " +
                                 Path("run.csv"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  void ExpectCleanFailure(const CliResult& result,
                          const std::string& expected) {
    EXPECT_EQ(result.exit_code, 1) << result.output;
    EXPECT_EQ(CountLines(result.output), 1) << result.output;
    EXPECT_NE(result.output.find(expected), std::string::npos) << result.output;
    EXPECT_FALSE(fs::exists(Path("est.json")));
  }
};

TEST_F(EstimateCliTest, RecoversTheSimulatedStiffnesses) {
  Simulate("--set c_O1=3.7e6 --set c_V2=4.3e6");
  const CliResult r = RunKcrig("estimate --log " + Path("run.csv") +
                               " --init-scale 1.05 --out " + Path("est.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("N/mm"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("log10 diag"), std::string::npos) << r.output;
  const nlohmann::json est =
      nlohmann::json::parse(std::ifstream(Path("est.json")));
  EXPECT_EQ(est["converged"], true);
  const double truth[] = {3.7e6, 4.0e6, 4.0e6, 4.3e6, 4.0e6};
  ASSERT_EQ(est["parameters"].size(), 5u);
  for (int i = 0; i < 5; ++i) {
    const double value = est["parameters"][i]["value"];
    EXPECT_NEAR(value / truth[i], 1.0, 1e-6) << est["parameters"][i]["name"];
  }
  for (const char* key : {"covariance", "correlation", "singular_values",
                          "residual_rms", "cost", "iterations"}) {
    EXPECT_TRUE(est.contains(key)) << key;
  }
  // A result, not a timing: the same bytes from the same logs.
  EXPECT_FALSE(est.contains("seconds"));
  EXPECT_EQ(est["parameters"][0]["log10_diag_inv_jtj"].is_number(), true);
}

TEST_F(EstimateCliTest, SubsetOfParametersAndChannels) {
  Simulate("--set c_P=3.8e6 --noise --seed 5");
  const CliResult r =
      RunKcrig("estimate --log " + Path("run.csv") +
               " --params c_P,c_O2 --channels y,toe,camber " +
               "--init c_P=4.1e6 --profile --out " + Path("est.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json est =
      nlohmann::json::parse(std::ifstream(Path("est.json")));
  ASSERT_EQ(est["parameters"].size(), 2u);
  EXPECT_EQ(est["parameters"][0]["name"], "c_P");
  const double low = est["parameters"][0]["ci95"][0];
  const double high = est["parameters"][0]["ci95"][1];
  EXPECT_LT(low, 3.8e6);
  EXPECT_GT(high, 3.8e6);
  EXPECT_TRUE(est["residual_rms"]["x"].is_null());
  EXPECT_TRUE(est["residual_rms"]["toe"].is_number());
  ASSERT_EQ(est["profiles"].size(), 2u);
  EXPECT_EQ(est["profiles"][0]["identifiability"], "identifiable");
  const double profile_low = est["profiles"][0]["ci95_profile"][0];
  EXPECT_LT(profile_low, 3.8e6);
  EXPECT_NE(r.output.find("profile c_P"), std::string::npos) << r.output;
}

TEST_F(EstimateCliTest, ScreenWritesRankingAndProposal) {
  Simulate("");
  const CliResult r =
      RunKcrig("screen --log " + Path("run.csv") + " --trajectories 6 --out " +
               Path("screen.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("proposed estimable subset"), std::string::npos);
  const nlohmann::json screen =
      nlohmann::json::parse(std::ifstream(Path("screen.json")));
  EXPECT_EQ(screen["ranking"].size(), 5u);
  EXPECT_EQ(screen["ranking"][0]["rank"], 1);
  EXPECT_EQ(screen["evaluations"], 6 * 6);
  const CliResult bad = RunKcrig("screen --log " + Path("run.csv") +
                                 " --range-low 2 --out " + Path("bad.json"));
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_EQ(CountLines(bad.output), 1) << bad.output;
  EXPECT_FALSE(fs::exists(Path("bad.json")));
}

// One ramp near one direction fitted, one in another predicted: with a
// rig compliance in the plant the fit looks fine but mispredicts the
// hold-out, and the output says so and names the diagnosis; without it
// both are adequate.
TEST_F(EstimateCliTest, HoldoutPredictionCatchesAnAbsorbedEffect) {
  for (const std::string effect : {"", " --effect rig_compliance:k=2e7"}) {
    for (const char* name : {"a", "h"}) {
      const std::string phi = std::string(name) == "a" ? "85" : "0";
      const CliResult sim = RunKcrig(
          "simulate --duration 1 --noise --seed " +
          std::string(name == std::string("a") ? "1" : "2") + " --phi " + phi +
          effect + " --out " + Path(std::string(name) + ".csv"));
      ASSERT_EQ(sim.exit_code, 0) << sim.output;
    }
    const CliResult r =
        RunKcrig("estimate --log " + Path("a.csv") + " --holdout " +
                 Path("h.csv") + " --out " + Path("est.json"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const nlohmann::json est =
        nlohmann::json::parse(std::ifstream(Path("est.json")));
    ASSERT_TRUE(est.contains("adequacy"));
    ASSERT_TRUE(est.contains("prediction"));
    EXPECT_EQ(est["prediction"]["logs"][0], Path("h.csv"));
    const nlohmann::json& prediction = est["prediction"]["adequacy"];
    if (effect.empty()) {
      EXPECT_EQ(est["adequacy"]["verdict"], "adequate") << r.output;
      EXPECT_EQ(prediction["verdict"], "adequate") << r.output;
      EXPECT_EQ(r.output.find("not to be trusted"), std::string::npos);
    } else {
      EXPECT_EQ(prediction["verdict"], "inadequate") << r.output;
      EXPECT_GT(prediction["score"].get<double>(), 1.2) << r.output;
      EXPECT_NE(r.output.find("not to be trusted"), std::string::npos)
          << r.output;
      EXPECT_NE(r.output.find("kcrig diagnose --log " + Path("a.csv")),
                std::string::npos)
          << r.output;
    }
    for (const char* channel : {"x", "toe", "caster"}) {
      EXPECT_TRUE(prediction["channels"][channel]["score"].is_number())
          << channel;
    }
  }
}

TEST_F(EstimateCliTest, BadInputFailsCleanly) {
  Simulate("");
  const std::string log = " --log " + Path("run.csv");
  const std::string out = " --out " + Path("est.json");
  ExpectCleanFailure(RunKcrig("estimate --log " + Path("none.csv") + out),
                     "none.csv: cannot open");
  ExpectCleanFailure(RunKcrig("estimate" + log + " --params c_X1" + out),
                     "--params: unknown parameter 'c_X1'");
  ExpectCleanFailure(RunKcrig("estimate" + log + " --params c_O1,c_O1" + out),
                     "given twice");
  ExpectCleanFailure(RunKcrig("estimate" + log + " --channels x,yaw" + out),
                     "unknown channel 'yaw'");
  ExpectCleanFailure(RunKcrig("estimate" + log + " --init c_O1=abc" + out),
                     "'abc' is not a number");
  ExpectCleanFailure(RunKcrig("estimate" + log + " --init k_spring=1e5" + out),
                     "not among the estimated parameters");
  ExpectCleanFailure(RunKcrig("estimate" + log + " --init-scale 20" + out),
                     "outside the bounds");
  ExpectCleanFailure(
      RunKcrig("estimate" + log + " --holdout " + Path("none.csv") + out),
      "none.csv: cannot open");
  // A fresh log whose Fx at t = 0.5 s reads `field`.
  auto with_fx = [&](const std::string& field) {
    Simulate("");
    std::ifstream in(Path("run.csv"));
    std::string text((std::istreambuf_iterator<char>(in)), {});
    const size_t line_start = text.find("\n0.5,") + 1;
    text.replace(line_start, text.find(',', line_start + 4) - line_start,
                 "0.5," + field);
    std::ofstream(Path("run.csv")) << text;
  };
  // A corrupt log: a NaN in the middle.
  with_fx("nan");
  ExpectCleanFailure(RunKcrig("estimate" + log + out), "not a finite number");
  // A force no rig applies (a unit slip, a corrupt field): refused in one
  // line, no solver output.
  with_fx("1.7e308");
  ExpectCleanFailure(RunKcrig("estimate" + log + out),
                     "column 'Fx': 1.7e+308 is beyond any rig (|value| <= "
                     "1e+06 N)");
  // Forces a rig could log but no suspension survives: the solver fails,
  // and says so in kcrig's one line, never through its own logging.
  {
    Simulate("");
    std::ifstream in(Path("run.csv"));
    std::vector<std::string> lines;
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    for (size_t j = 300; j + 1 < lines.size(); j += 7) {
      const size_t fx = lines[j].find(',') + 1;
      const size_t fz = lines[j].find(',', lines[j].find(',', fx) + 1);
      lines[j] = lines[j].substr(0, fx) + "9.9e5,-9.9e5" + lines[j].substr(fz);
    }
    std::ofstream out(Path("run.csv"));
    for (const std::string& line : lines) out << line << "\n";
  }
  ExpectCleanFailure(RunKcrig("estimate" + log + out), "estimation failed");
  // A field carrying terminal escapes (set the title, clear the screen) and
  // a stray C1 byte: echoed as \xNN, never raw.
  with_fx("\x1b]0;pwned\x07\x1b[2J\x9b");
  const CliResult escaped = RunKcrig("estimate" + log + out);
  ExpectCleanFailure(escaped, "\\x1b]0;pwned\\x07\\x1b[2J\\x9b");
  for (const char byte : escaped.output) {
    const auto code = static_cast<unsigned char>(byte);
    EXPECT_TRUE(code == '\n' || (code >= 0x20 && code != 0x7f && code < 0x80))
        << static_cast<int>(code) << " in " << escaped.output;
  }
}

// An output never destroys an input (the log, its sidecar, est.json read
// by design) and never replaces what is not a regular file (a FIFO, a
// symbolic link): one line, exit 1, everything as it was.
TEST_F(EstimateCliTest, OutputsNeverReplaceAnInputOrASpecialFile) {
  Simulate("");
  const std::string log = "estimate --log " + Path("run.csv") + " --out ";
  const auto size_of_log = fs::file_size(Path("run.csv"));
  const auto size_of_sidecar = fs::file_size(Path("run.json"));
  ExpectCleanFailure(RunKcrig(log + Path("run.csv")),
                     "run.csv: is also an input");
  ExpectCleanFailure(RunKcrig(log + Path("run.json")),
                     "run.json: is also an input");
  ASSERT_EQ(RunCommand("mkfifo " + Path("fifo")).exit_code, 0);
  fs::create_symlink(Path("run.csv"), Path("link.json"));
  ExpectCleanFailure(RunKcrig(log + Path("fifo")),
                     "fifo: is a device or FIFO, not a regular file");
  ExpectCleanFailure(RunKcrig(log + Path("link.json")),
                     "link.json: is a symbolic link, not a regular file");
  EXPECT_TRUE(fs::is_fifo(Path("fifo")));
  EXPECT_TRUE(fs::is_symlink(Path("link.json")));
  EXPECT_EQ(fs::file_size(Path("run.csv")), size_of_log);
  EXPECT_EQ(fs::file_size(Path("run.json")), size_of_sidecar);
  // design reads est.json: writing design.json over it is refused too.
  ASSERT_EQ(RunKcrig(log + Path("est.json")).exit_code, 0);
  const CliResult design = RunKcrig("design --estimate " + Path("est.json") +
                                    " --out " + Path("est.json"));
  EXPECT_EQ(design.exit_code, 1) << design.output;
  EXPECT_EQ(CountLines(design.output), 1) << design.output;
  EXPECT_NE(design.output.find("est.json: is also an input"), std::string::npos)
      << design.output;
  // A config path that is a symbolic link loop: one line, not an abort.
  fs::create_symlink(Path("loop"), Path("loop"));
  const CliResult looped = RunKcrig("estimate --config " + Path("loop") +
                                    " --log " + Path("run.csv"));
  EXPECT_EQ(looped.exit_code, 1) << looped.output;
  EXPECT_EQ(CountLines(looped.output), 1) << looped.output;
}

// A long log's fit holds no more per sample than the up-front memory check
// assumes (estimator/internal/fit_problem.h: 1616 B per sample for six
// channels and five parameters): the check that refuses a log too long for
// the machine must not let through one that then exhausts it. The growth
// between a 10 s and a 40 s log at 1 kHz is measured, so fixed costs cancel.
TEST_F(EstimateCliTest, PeakMemoryPerSampleIsWhatTheCheckAssumes) {
#if defined(KCRIG_SANITIZED)
  GTEST_SKIP() << "under AddressSanitizer the resident set measures the "
                  "sanitizer's shadow and quarantine, not the fit";
#endif
  auto peak_kib = [&](int seconds) {
    const std::string log = Path("run" + std::to_string(seconds) + ".csv");
    const CliResult simulated =
        RunKcrig("simulate --noise --duration " + std::to_string(seconds) +
                 " --out " + log);
    EXPECT_EQ(simulated.exit_code, 0) << simulated.output;
    ChildProcess estimate({KCRIG_BINARY, "estimate", "--log", log, "--out",
                           Path("est" + std::to_string(seconds) + ".json")},
                          Path("estimate.out"));
    EXPECT_EQ(estimate.Wait(120), 0) << estimate.Output();
    return static_cast<double>(estimate.peak_rss_kib());
  };
  const double short_log = peak_kib(10);
  const double long_log = peak_kib(40);
  const double bytes_per_sample = (long_log - short_log) * 1024.0 / 30000.0;
  std::printf(
      "peak resident set: %.0f KiB for 10 s, %.0f KiB for 40 s: %.0f "
      "B per sample\n",
      short_log, long_log, bytes_per_sample);
  EXPECT_GT(bytes_per_sample, 200.0);  // the measure sees the fit at all
  EXPECT_LT(bytes_per_sample, 1616.0);
}

}  // namespace
}  // namespace kcrig
