// Issue #22: `kcrig validate` through the real CLI, alone and under mpirun.
// The same cases give byte-identical validate.json on 1, 2 and 3 ranks (and
// without mpirun); a killed rank ends the job naming it and writes nothing;
// bad input is one line naming the option.
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/support/cli_runner.h"
#include "tests/support/temp_dir_test.h"

namespace kcrig {
namespace {

// mpirun as the CI's root too, oversubscribed on two cores.
const std::string kMpirun =
    "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 "
    "mpirun --oversubscribe ";
// Cheap cases: two clean ones and a rig compliance.
const std::string kCases =
    " validate --quiet --cases 3 --effects none,rig_compliance --seed 3";

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

class ValidateCliTest : public TempDirTest {};

TEST_F(ValidateCliTest, ResultsAreIdenticalOnOneTwoAndThreeRanks) {
  const CliResult alone = RunKcrig(kCases + " --out " + Path("alone.json"));
  ASSERT_EQ(alone.exit_code, 0) << alone.output;
  EXPECT_NE(alone.output.find("3 cases on 1 rank"), std::string::npos);
  const std::string expected = ReadFile(Path("alone.json"));
  const nlohmann::json doc = nlohmann::json::parse(expected);
  ASSERT_EQ(doc["case_results"].size(), 3u);
  EXPECT_EQ(doc["figures"]["clean"]["total"], 2);
  for (int ranks : {1, 2, 3}) {
    const std::string out = Path("np" + std::to_string(ranks) + ".json");
    const CliResult run =
        RunCommand(kMpirun + "-np " + std::to_string(ranks) + " " +
                   KCRIG_BINARY + kCases + " --out " + out);
    ASSERT_EQ(run.exit_code, 0) << run.output;
    EXPECT_NE(run.output.find("3 cases on " + std::to_string(ranks) + " rank"),
              std::string::npos)
        << run.output;
    EXPECT_EQ(ReadFile(out), expected) << ranks << " ranks";
  }
}

// The rank's process id, found by its MPI rank in its environment.
pid_t FindRank(int rank) {
  const std::string wanted =
      "OMPI_COMM_WORLD_RANK=" + std::to_string(rank) + '\0';
  for (const auto& entry : std::filesystem::directory_iterator("/proc")) {
    const std::string environment = ReadFile(entry.path() / "environ");
    const std::string command = ReadFile(entry.path() / "cmdline");
    if (command.find("validate") == std::string::npos) continue;
    if (command.find(KCRIG_BINARY) != 0) continue;
    if (environment.find(wanted) != std::string::npos) {
      return static_cast<pid_t>(std::stoi(entry.path().filename()));
    }
  }
  return 0;
}

TEST_F(ValidateCliTest, AKilledRankEndsTheJobAndNothingIsWritten) {
  const std::string out = Path("killed.json");
  std::thread killer([] {
    for (int attempt = 0; attempt < 200; ++attempt) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      if (const pid_t pid = FindRank(1); pid > 0) {
        std::this_thread::sleep_for(std::chrono::milliseconds(500));
        kill(pid, SIGKILL);
        return;
      }
    }
  });
  const CliResult run =
      RunCommand(kMpirun + "-np 2 " + KCRIG_BINARY +
                 " validate --quiet --cases 8 --effects rig_compliance "
                 "--out " +
                 out);
  killer.join();
  EXPECT_NE(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("rank 1"), std::string::npos) << run.output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST_F(ValidateCliTest, BadInputIsOneLineNamingTheOption) {
  const std::string out = Path("bad.json");
  for (const std::string& arguments :
       {std::string("--effects hysteresis,bogus"), std::string("--cases 0"),
        std::string("--threads 0")}) {
    const CliResult run =
        RunKcrig("validate --quiet " + arguments + " --out " + out);
    EXPECT_EQ(run.exit_code, 1) << arguments << ": " << run.output;
    EXPECT_EQ(CountLines(run.output), 1) << run.output;
    EXPECT_NE(run.output.find(arguments.substr(0, arguments.find(' '))),
              std::string::npos)
        << run.output;
    EXPECT_FALSE(std::filesystem::exists(out));
  }
}

}  // namespace
}  // namespace kcrig
