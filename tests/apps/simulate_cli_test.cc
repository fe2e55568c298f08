// Acceptance 5 (foundation issue) and the CLI contract: the real kcrig
// binary, run as a user runs it.
#include <sys/stat.h>
#include <unistd.h>

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

using Result = CliResult;

class SimulateCliTest : public TempDirTest {
 protected:
  void TearDown() override {
    fs::permissions(dir_, fs::perms::owner_all);  // a test makes it read-only
    TempDirTest::TearDown();
  }
  // A failed run: non-zero exit, one line naming `expected`, and nothing
  // written into the output directory.
  void ExpectCleanFailure(const Result& result, const std::string& expected) {
    EXPECT_NE(result.exit_code, 0) << result.output;
    EXPECT_EQ(CountLines(result.output), 1) << result.output;
    EXPECT_NE(result.output.find(expected), std::string::npos) << result.output;
    EXPECT_TRUE(fs::is_empty(dir_)) << "partial output left behind";
  }
  std::string Out() const { return (dir_ / "run.csv").string(); }
};

TEST_F(SimulateCliTest, HelpListsTheSubcommand) {
  const Result result = RunKcrig("--help");
  EXPECT_EQ(result.exit_code, 0);
  EXPECT_NE(result.output.find("simulate"), std::string::npos);
  const Result sub = RunKcrig("simulate --help");
  EXPECT_EQ(sub.exit_code, 0);
  EXPECT_NE(sub.output.find("--phi"), std::string::npos);
}

TEST_F(SimulateCliTest, UnknownSubcommandAndOptionFailInOneLine) {
  ExpectCleanFailure(RunKcrig("frobnicate"), "unknown subcommand 'frobnicate'");
  ExpectCleanFailure(RunKcrig("simulate --bogus"), "--bogus");
  ExpectCleanFailure(RunKcrig("simulate --phi abc"), "--phi");
  ExpectCleanFailure(RunKcrig(""), "subcommand");
}

TEST_F(SimulateCliTest, WritesCsvAndSidecarPerContract) {
  const Result result = RunKcrig(
      "simulate --phi 85 --z -0.45 --fmax 3000 "
      "--duration 0.5 --rate 500 --set c_O1=4.2e6 "
      "--noise --seed 3 --out " +
      Out());
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_NE(result.output.find("mm/kN"), std::string::npos) << result.output;

  std::ifstream csv(Out());
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "t,Fx,Fy,Fz,x,y,z,toe,camber,caster");
  int rows = 0;
  std::string last;
  while (std::getline(csv, line)) {
    ++rows;
    last = line;
  }
  EXPECT_EQ(rows, 251);  // 0.5 s at 500 Hz, both ends included
  EXPECT_EQ(last.substr(0, last.find(',')), "0.5");

  const nlohmann::json sidecar =
      nlohmann::json::parse(std::ifstream(dir_ / "run.json"));
  EXPECT_EQ(sidecar["units"]["t"], "s");
  EXPECT_EQ(sidecar["units"]["Fx"], "N");
  EXPECT_EQ(sidecar["units"]["z"], "m");
  EXPECT_EQ(sidecar["units"]["camber"], "rad");
  EXPECT_EQ(sidecar["rate_hz"], 500.0);
  EXPECT_NEAR(sidecar["excitation"]["phi_rad"].get<double>(),
              85.0 * M_PI / 180.0, 1e-12);
  EXPECT_EQ(sidecar["excitation"]["z_a_m"], -0.45);
  EXPECT_EQ(sidecar["excitation"]["fmax_n"], 3000.0);
  EXPECT_EQ(sidecar["excitation"]["tf_s"], 0.5);
  EXPECT_EQ(sidecar["truth"]["parameters"]["c_O1"], 4.2e6);
  EXPECT_EQ(sidecar["noise"]["seed"], 3);
  EXPECT_EQ(sidecar["noise"]["added"], true);
  EXPECT_EQ(sidecar["transport"], "simulation");
}

TEST_F(SimulateCliTest, SameSeedSameNoise) {
  ASSERT_EQ(RunKcrig("simulate --duration 0.1 --noise --seed 9 --out " + Out())
                .exit_code,
            0);
  std::ifstream a(Out());
  const std::string first((std::istreambuf_iterator<char>(a)), {});
  ASSERT_EQ(RunKcrig("simulate --duration 0.1 --noise --seed 9 --out " + Out())
                .exit_code,
            0);
  std::ifstream b(Out());
  const std::string second((std::istreambuf_iterator<char>(b)), {});
  EXPECT_EQ(first, second);
}

TEST_F(SimulateCliTest, ReadOnlyOutputDirectoryFailsCleanly) {
  fs::permissions(dir_, fs::perms::owner_read | fs::perms::owner_exec |
                            fs::perms::group_read | fs::perms::group_exec |
                            fs::perms::others_read | fs::perms::others_exec);
  // Root ignores permission bits; in a user namespace it is an ordinary
  // user towards files it does not own there.
  const std::string prefix = geteuid() == 0 ? "unshare --user " : "";
  const Result result =
      RunKcrig("simulate --duration 0.1 --out " + Out(), prefix);
  ExpectCleanFailure(result, Out() + ": cannot write: Permission denied");
}

TEST_F(SimulateCliTest, MalformedSetFailsCleanly) {
  ExpectCleanFailure(RunKcrig("simulate --set c_O1 --out " + Out()),
                     "--set c_O1: expected NAME=VALUE");
  ExpectCleanFailure(RunKcrig("simulate --set c_O1=4e6N --out " + Out()),
                     "'4e6N' is not a number");
  ExpectCleanFailure(RunKcrig("simulate --set c_X9=4e6 --out " + Out()),
                     "unknown parameter 'c_X9'");
  ExpectCleanFailure(RunKcrig("simulate --set mass=-1 --out " + Out()),
                     "--set: mass: must be within (0, 1e4] kg");
}

TEST_F(SimulateCliTest, NanParameterFailsCleanly) {
  ExpectCleanFailure(RunKcrig("simulate --set c_P=nan --out " + Out()),
                     "--set c_P=nan: value must be finite");
  ExpectCleanFailure(RunKcrig("simulate --fmax nan --out " + Out()), "--fmax");
}

// CLI11 alone would read "" as 0, "0x10" as 16 and "-1" into an unsigned
// seed as 2^64 - 1: every number on the command line is decimal, finite
// and within the option's range.
TEST_F(SimulateCliTest, NumbersAreDecimalFiniteAndInRange) {
  const struct {
    std::string arguments, message;
  } cases[] = {
      {"--fmax ''", "--fmax: "},
      {"--fmax 0x10", "--fmax: '0x10' is not a finite decimal number"},
      {"--fmax 1e400", "--fmax: "},
      {"--seed -1", "--seed: '-1' is not a decimal whole number >= 0"},
      {"--seed 0x1f", "--seed: '0x1f' is not a decimal whole number >= 0"},
      {"--phi 1e300", "--phi: Value 1e300 not in range"},
      {"--duration 1e9", "--duration: Value 1e9 not in range"},
      {"--fmax -5", "--fmax: Value -5 not in range"},
  };
  for (const auto& c : cases) {
    ExpectCleanFailure(RunKcrig("simulate " + c.arguments + " --out " + Out()),
                       c.message);
  }
  ExpectCleanFailure(
      RunKcrig("screen --trajectories 1000000000 --log " + Out()),
      "--trajectories: Value 1000000000 not in range");
  // A slower loop stretches rig.yaml's cycle counts: 20 watchdog cycles at
  // 10 Hz would be 2 s without a sample.
  ExpectCleanFailure(
      RunKcrig("timing-check --rate 10 --quiet --out " + Out()),
      "--rate: rig.yaml safety.watchdog_cycles: 20 cycles are more than 1 s "
      "at this period");
  // An address that is not one (it once listened on 255.255.255.255).
  ExpectCleanFailure(RunKcrig("emulate --modbus-tcp 300.1.1.1:1502"),
                     "host '300.1.1.1' must be an IPv4 address");
  ExpectCleanFailure(
      RunKcrig("run --rig modbus-tcp://300.1.1.1:1502 --log-dir " +
               (dir_ / "run").string()),
      "host '300.1.1.1' must be an IPv4 address");
}

TEST_F(SimulateCliTest, InconsistentRateAndEffectsFailCleanly) {
  ExpectCleanFailure(RunKcrig("simulate --rate 300 --out " + Out()),
                     "whole multiple of the plant's integration step 0.001");
  ExpectCleanFailure(RunKcrig("simulate --plant-step 3e-4 --out " + Out()),
                     "whole multiple of the plant's integration step 0.0003");
  ExpectCleanFailure(RunKcrig("simulate --plant-step 2e-3 --out " + Out()),
                     "--plant-step: must be within (0, integrator.step");
  ExpectCleanFailure(
      RunKcrig("simulate --effect hysteresis:force=-3 --out " + Out()),
      "'force=-3': must be a number within (0, 100000] N");
  ExpectCleanFailure(
      RunKcrig("simulate --effect rig_compliance:q=3 --out " + Out()),
      "unknown parameter of rig_compliance (one of k, k_rot, at)");
  ExpectCleanFailure(RunKcrig("simulate --effect wobble --out " + Out()),
                     "unknown effect 'wobble'");
  ExpectCleanFailure(RunKcrig("simulate --config /nonexistent --out " + Out()),
                     "/nonexistent: config directory not found");
}

}  // namespace
}  // namespace kcrig
