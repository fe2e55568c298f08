// Progress lines of long commands: shown on a terminal (here a pseudo-
// terminal from util-linux's `script`), with the fraction done and the time
// left; absent with --quiet and when the output is not a terminal, so logs
// and pipes stay clean.
#include <string>

#include "gtest/gtest.h"
#include "tests/support/cli_runner.h"
#include "tests/support/temp_dir_test.h"

namespace kcrig {
namespace {

// The line is rewritten in place: carriage return, erase to end of line.
constexpr const char* kRewrite = "\r\033[K";

class ProgressCliTest : public TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    const CliResult sim = RunKcrig(
        "simulate --noise --seed 2 --duration 1.5 --out " + Path("run.csv"));
    ASSERT_EQ(sim.exit_code, 0) << sim.output;
  }
  // Runs kcrig with its stdout and stderr on a pseudo-terminal.
  CliResult OnTerminal(const std::string& arguments) {
    return RunCommand("script -qec \"" + std::string(KCRIG_BINARY) + " " +
                      arguments + "\" /dev/null");
  }
};

TEST_F(ProgressCliTest, ScreeningShowsEvaluationsAndTimeLeftOnATerminal) {
  const std::string args = "screen --log " + Path("run.csv");
  const CliResult tty = OnTerminal(args);
  ASSERT_EQ(tty.exit_code, 0) << tty.output;
  EXPECT_NE(tty.output.find(kRewrite), std::string::npos) << tty.output;
  EXPECT_NE(tty.output.find("/120 model evaluations |"), std::string::npos)
      << tty.output;
  EXPECT_NE(tty.output.find("s left"), std::string::npos) << tty.output;
  // The results are printed after the line is erased, never on it.
  EXPECT_NE(
      tty.output.find(std::string(kRewrite) + "kcrig screen: 5 candidates"),
      std::string::npos)
      << tty.output;

  const CliResult quiet = OnTerminal(args + " --quiet");
  ASSERT_EQ(quiet.exit_code, 0) << quiet.output;
  EXPECT_EQ(quiet.output.find("\033[K"), std::string::npos) << quiet.output;

  const CliResult piped = RunKcrig(args);
  ASSERT_EQ(piped.exit_code, 0) << piped.output;
  EXPECT_EQ(piped.output.find("\033[K"), std::string::npos) << piped.output;
}

TEST_F(ProgressCliTest, DiagnosisShowsItsStagesAndTimeLeftOnATerminal) {
  const std::string args = "diagnose --log " + Path("run.csv");
  const CliResult tty = OnTerminal(args);
  ASSERT_EQ(tty.exit_code, 0) << tty.output;
  EXPECT_NE(tty.output.find("kcrig diagnose: nominal fit |"), std::string::npos)
      << tty.output;
  EXPECT_NE(tty.output.find("kcrig diagnose: localisation and per-log fits | "
                            "10 %"),
            std::string::npos)
      << tty.output;
  EXPECT_NE(tty.output.find("s left"), std::string::npos) << tty.output;

  const CliResult piped = RunKcrig(args);
  ASSERT_EQ(piped.exit_code, 0) << piped.output;
  EXPECT_EQ(piped.output.find("\033[K"), std::string::npos) << piped.output;
  EXPECT_EQ(piped.output.find("s left"), std::string::npos) << piped.output;
}

}  // namespace
}  // namespace kcrig
