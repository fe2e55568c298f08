// Issue #22: `kcrig validate`, `design`, `diagnose` and `campaign --rig sim`
// through the real CLI, alone and under mpirun. The same cases give
// byte-identical validate.json on 1, 2 and 3 ranks (and without mpirun), the
// same design and the same logs the same design.json and diag.json, and the
// campaign the same folder, byte for byte; a killed rank ends the job naming
// it and writes nothing; the other commands (and a campaign on a real rig)
// refuse several ranks; bad input to validate is one line naming the option.
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <thread>

#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/support/cli_runner.h"
#include "tests/support/temp_dir_test.h"

namespace kcrig {
namespace {

// mpirun as the CI's root too, oversubscribed on two cores, one node's
// shared memory as the transport (no network probing, no warnings about it
// in the output compared below).
const std::string kMpirun =
    "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 "
    "OMPI_MCA_btl=self,vader mpirun --oversubscribe ";
// Cheap cases: two clean ones and a rig compliance.
const std::string kCases =
    " validate --quiet --cases 3 --effects none,rig_compliance --seed 3";

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

class ClusterCliTest : public TempDirTest {
 protected:
  // mpirun with the ranks' temporary folders in the test's own folder,
  // which TempFolderIsEmpty then checks.
  std::string Mpirun() const {
    std::filesystem::create_directories(Path("tmp"));
    return kMpirun + "-x TMPDIR=" + Path("tmp") + " ";
  }
  // Two 1 s logs of a plant with hysteresis, `prefix`a.csv and b.csv.
  bool SimulateTwoLogs(const std::string& prefix) const {
    for (const char* log : {"a", "b"}) {
      const bool first = log[0] == 'a';
      const CliResult sim = RunKcrig(
          std::string("simulate --noise --seed ") + (first ? "1" : "2") +
          " --phi " + (first ? "80" : "25") +
          " --z -0.3 --duration 1 --return 1 --effect hysteresis:force=200 "
          "--out " +
          prefix + log + ".csv");
      EXPECT_EQ(sim.exit_code, 0) << sim.output;
      if (sim.exit_code != 0) return false;
    }
    return true;
  }
  // No rank left a private folder behind (a killed one cannot).
  void ExpectNoPrivateFolderLeft() const {
    EXPECT_TRUE(std::filesystem::is_empty(Path("tmp")));
  }
  // `command` started in a session of its own, every process of the
  // session sent `signal` once the checkpoint `folder` keeps `items` cases
  // (or when the command ended first): as a scheduler ends a job, every
  // rank at once (mpirun puts its ranks in process groups of their own).
  static CliResult SignalWhenKept(const std::string& command,
                                  const std::string& folder, int items,
                                  const std::string& signal) {
    return RunCommand(
        "setsid " + command +
        " 2>&1 & pid=$!; while kill -0 $pid 2>/dev/null &&"
        " [ $(ls " +
        folder + " 2>/dev/null | grep -c '^item-[0-9]*\\.json$') -lt " +
        std::to_string(items) + " ]; do sleep 0.02; done; pkill -" + signal +
        " -s $pid; wait $pid; while pgrep -s $pid "
        ">/dev/null; do sleep 0.05; done");
  }
  static int KeptItems(const std::string& folder) {
    int items = 0;
    std::error_code missing;
    for (const auto& entry :
         std::filesystem::directory_iterator(folder, missing)) {
      items += std::regex_match(entry.path().filename().string(),
                                std::regex(R"(item-\d+\.json)"));
    }
    return items;
  }
  // kcrig `arguments` under mpirun on `ranks` ranks, writing `out`.
  CliResult OnRanks(int ranks, const std::string& arguments,
                    std::string* out) const {
    *out = Path("np" + std::to_string(ranks) + ".json");
    return RunCommand(Mpirun() + "-np " + std::to_string(ranks) + " " +
                      KCRIG_BINARY + arguments + " --out " + *out);
  }
};

TEST_F(ClusterCliTest, ResultsAreIdenticalOnOneTwoAndThreeRanks) {
  const CliResult alone = RunKcrig(kCases + " --out " + Path("alone.json"));
  ASSERT_EQ(alone.exit_code, 0) << alone.output;
  EXPECT_NE(alone.output.find("3 cases on 1 rank"), std::string::npos);
  const std::string expected = ReadFile(Path("alone.json"));
  const nlohmann::json doc = nlohmann::json::parse(expected);
  ASSERT_EQ(doc["case_results"].size(), 3u);
  EXPECT_EQ(doc["figures"]["clean"]["total"], 2);
  for (int ranks : {1, 2, 3}) {
    std::string out;
    const CliResult run = OnRanks(ranks, kCases, &out);
    ASSERT_EQ(run.exit_code, 0) << run.output;
    EXPECT_NE(run.output.find("3 cases on " + std::to_string(ranks) + " rank"),
              std::string::npos)
        << run.output;
    EXPECT_EQ(ReadFile(out), expected) << ranks << " ranks";
  }
}

TEST_F(ClusterCliTest, DesignBatchesGiveTheSameDesignOnOneTwoAndThreeRanks) {
  const std::string design =
      " design --quiet --optimizer grid,kriging --grid 4x3 --budget 13";
  const CliResult alone = RunKcrig(design + " --out " + Path("alone.json"));
  ASSERT_EQ(alone.exit_code, 0) << alone.output;
  const std::string expected = ReadFile(Path("alone.json"));
  const size_t at = alone.output.find("  optimal design:");
  ASSERT_NE(at, std::string::npos) << alone.output;
  const std::string optimum =
      alone.output.substr(at, alone.output.find('\n', at) - at);
  for (int ranks : {1, 2, 3}) {
    std::string out;
    const CliResult run = OnRanks(ranks, design, &out);
    ASSERT_EQ(run.exit_code, 0) << run.output;
    // Rank 0 alone prints: the same lines as alone (wall times aside).
    EXPECT_EQ(CountLines(run.output), CountLines(alone.output)) << run.output;
    EXPECT_NE(run.output.find(optimum), std::string::npos) << run.output;
    EXPECT_EQ(ReadFile(out), expected) << ranks << " ranks";
  }
}

TEST_F(ClusterCliTest, CandidateFitsGiveTheSameDiagnosisOnOneTwoAndThreeRanks) {
  ASSERT_TRUE(SimulateTwoLogs(Path("")));
  const std::string diagnose =
      " diagnose --quiet --log " + Path("a.csv") + " --log " + Path("b.csv") +
      " --candidates hysteresis,bushing_damping,rig_compliance --no-pairs";
  const CliResult alone = RunKcrig(diagnose + " --out " + Path("alone.json"));
  ASSERT_EQ(alone.exit_code, 0) << alone.output;
  const std::string expected = ReadFile(Path("alone.json"));
  EXPECT_EQ(nlohmann::json::parse(expected)["verdict"], "hysteresis")
      << alone.output;
  for (int ranks : {1, 2, 3}) {
    std::string out;
    const CliResult run = OnRanks(ranks, diagnose, &out);
    ASSERT_EQ(run.exit_code, 0) << run.output;
    EXPECT_EQ(CountLines(run.output), CountLines(alone.output)) << run.output;
    EXPECT_EQ(ReadFile(out), expected) << ranks << " ranks";
  }
}

// Every file under `dir` (relative path -> bytes).
std::map<std::string, std::string> Folder(const std::string& dir) {
  std::map<std::string, std::string> files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(dir)) {
    if (!entry.is_regular_file()) continue;
    files[std::filesystem::relative(entry.path(), dir).string()] =
        ReadFile(entry.path().string());
  }
  return files;
}

TEST_F(ClusterCliTest, ACampaignOnRanksWritesTheSameFolderAsAlone) {
  // A soft fixture: the first check fails, the diagnosis' candidate fits
  // and the designs spread, an effect is adopted.
  const std::string out = Path("campaign");
  const std::string campaign =
      " campaign --iterations 1 --budget 12 --quiet --no-report "
      "--plant-effect rig_compliance:k=1e7 --out " +
      out;
  const CliResult alone = RunKcrig(campaign);
  ASSERT_EQ(alone.exit_code, 0) << alone.output;
  EXPECT_NE(alone.output.find("the next experiment is the one that tells "
                              "them apart"),
            std::string::npos)
      << alone.output;
  EXPECT_NE(alone.output.find("adopted"), std::string::npos) << alone.output;
  const std::map<std::string, std::string> expected = Folder(out);
  ASSERT_TRUE(expected.count("campaign.json"));
  ASSERT_TRUE(expected.count("iteration_1/run.csv"));
  for (int ranks : {1, 2, 3}) {
    std::filesystem::remove_all(out);
    const CliResult run = RunCommand(Mpirun() + "-np " + std::to_string(ranks) +
                                     " " + KCRIG_BINARY + campaign);
    ASSERT_EQ(run.exit_code, 0) << run.output;
    EXPECT_EQ(CountLines(run.output), CountLines(alone.output)) << run.output;
    const std::map<std::string, std::string> written = Folder(out);
    EXPECT_EQ(written.size(), expected.size()) << ranks << " ranks";
    for (const auto& [name, bytes] : expected) {
      EXPECT_TRUE(written.count(name) && written.at(name) == bytes)
          << name << " on " << ranks << " ranks";
    }
  }
  ExpectNoPrivateFolderLeft();
}

TEST_F(ClusterCliTest, ACampaignErrorOfOneRankEndsTheJobNamingIt) {
  // Rank 1 alone has no temporary folder (MPMD: its own environment).
  const std::string campaign =
      " campaign --iterations 1 --budget 12 --quiet --no-report --out " +
      Path("campaign");
  const CliResult run = RunCommand(
      Mpirun() + "-np 1 " + KCRIG_BINARY + campaign +
      " : -np 1 env TMPDIR=/dev/null/none " + KCRIG_BINARY + campaign);
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.output.find("kcrig campaign: rank 1: no temporary folder"),
            std::string::npos)
      << run.output;
  EXPECT_FALSE(std::filesystem::exists(Path("campaign") + "/campaign.json"));
}

TEST_F(ClusterCliTest, ACampaignOnARealRigRefusesSeveralRanks) {
  const CliResult run = RunCommand(
      Mpirun() + "-np 2 " + KCRIG_BINARY +
      " campaign --rig modbus-tcp://127.0.0.1:1 --out " + Path("campaign"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.output.find("kcrig campaign: rank 0: --rig "
                            "modbus-tcp://127.0.0.1:1: a rig's loop runs in "
                            "one process"),
            std::string::npos)
      << run.output;
  EXPECT_FALSE(std::filesystem::exists(Path("campaign")));
}

TEST_F(ClusterCliTest, RankZeroAloneReadsTheInputs) {
  // Rank 1 starts in an empty folder: the relative paths of the config and
  // the logs (and their sidecars) name nothing there, so it can only work
  // on rank 0's copies.
  const std::string here = Path("here"), elsewhere = Path("elsewhere");
  std::filesystem::create_directories(elsewhere);
  std::filesystem::create_directories(here);
  std::filesystem::copy(KCRIG_TEST_CONFIG_DIR, here + "/cfg",
                        std::filesystem::copy_options::recursive);
  ASSERT_TRUE(SimulateTwoLogs(here + "/"));
  const std::string diagnose =
      " diagnose --quiet --config cfg --log a.csv --log b.csv --candidates "
      "hysteresis,bushing_damping --no-pairs --out diag.json";
  const CliResult alone = RunCommand("cd " + here + " && " + KCRIG_BINARY +
                                     diagnose + " && mv diag.json alone.json");
  ASSERT_EQ(alone.exit_code, 0) << alone.output;
  const CliResult run = RunCommand(
      Mpirun() + "-np 1 --wdir " + here + " " + KCRIG_BINARY + diagnose +
      " : -np 1 --wdir " + elsewhere + " " + KCRIG_BINARY + diagnose);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_EQ(ReadFile(here + "/diag.json"), ReadFile(here + "/alone.json"));
  EXPECT_FALSE(std::filesystem::exists(elsewhere + "/diag.json"));
  ExpectNoPrivateFolderLeft();
}

TEST_F(ClusterCliTest, OtherCommandsRefuseSeveralRanks) {
  const CliResult run = RunCommand(Mpirun() + "-np 2 " + KCRIG_BINARY +
                                   " simulate --out " + Path("run.csv"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.output.find("kcrig simulate: runs in one process"),
            std::string::npos)
      << run.output;
  EXPECT_FALSE(std::filesystem::exists(Path("run.csv")));
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

TEST_F(ClusterCliTest, AKilledRankEndsTheJobAndNothingIsWritten) {
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
      RunCommand(Mpirun() + "-np 2 " + KCRIG_BINARY +
                 " validate --quiet --cases 8 --effects rig_compliance "
                 "--out " +
                 out);
  killer.join();
  EXPECT_NE(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("rank 1"), std::string::npos) << run.output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

void WriteFile(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
}

// Issue #52: a job killed at 30 % and at 90 % of its cases (SIGKILL, as a
// scheduler's wall-time limit ends it) goes on from its checkpoint with
// --resume, on as many ranks or others, to the same validate.json as an
// uninterrupted run, byte for byte; the checkpoint is gone once it is.
TEST_F(ClusterCliTest, AKilledJobResumesToTheSameResults) {
  const std::string cases =
      " validate --quiet --cases 10 --effects none,rig_compliance --seed 3";
  const CliResult whole = RunCommand(Mpirun() + "-np 2 " + KCRIG_BINARY +
                                     cases + " --out " + Path("whole.json"));
  ASSERT_EQ(whole.exit_code, 0) << whole.output;
  const std::string expected = ReadFile(Path("whole.json"));
  EXPECT_FALSE(std::filesystem::exists(Path("whole.json.checkpoint")));
  for (const auto& [kept, resume_ranks] : {std::pair{3, 2}, {9, 3}}) {
    const std::string out = Path("killed" + std::to_string(kept) + ".json");
    const std::string run =
        Mpirun() + "-np 2 " + KCRIG_BINARY + cases + " --out " + out;
    // The last cases run side by side and may end together before the
    // kill lands: then the job ran whole, and it is run again.
    for (int attempt = 0; attempt < 3; ++attempt) {
      std::filesystem::remove(out);
      SignalWhenKept("env " + run + " --resume", out + ".checkpoint", kept,
                     "KILL");
      if (!std::filesystem::exists(out)) break;
    }
    ASSERT_FALSE(std::filesystem::exists(out)) << "the job was not killed";
    const int items = KeptItems(out + ".checkpoint");
    EXPECT_GE(items, kept);
    EXPECT_LT(items, 10);
    // Without --resume the checkpoint is never overwritten.
    const CliResult again = RunCommand(run);
    EXPECT_EQ(again.exit_code, 1) << again.output;
    EXPECT_NE(again.output.find("--resume goes on from it"), std::string::npos)
        << again.output;
    const CliResult resumed = RunCommand(
        Mpirun() + "-np " + std::to_string(resume_ranks) + " " + KCRIG_BINARY +
        cases + " --out " + out + " --resume --timings " + out + ".csv");
    ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
    EXPECT_EQ(ReadFile(out), expected) << "killed after " << items;
    // Every case's cost, the kept ones' from the checkpoint.
    std::istringstream timings(ReadFile(out + ".csv"));
    std::string line;
    std::getline(timings, line);
    EXPECT_EQ(line, "case,truth,seconds");
    for (int i = 0; i < 10; ++i) {
      ASSERT_TRUE(std::getline(timings, line)) << i;
      const std::string truth = i % 2 == 0 ? "none" : "rig_compliance";
      EXPECT_EQ(line.rfind(std::to_string(i) + "," + truth + ",", 0), 0u)
          << line;
      EXPECT_GT(std::stod(line.substr(line.rfind(',') + 1)), 0.0) << line;
    }
    EXPECT_FALSE(std::filesystem::exists(out + ".checkpoint"));
  }
}

// A run stopped by Ctrl-C says where its cases are kept; a checkpoint of
// another seed, effects, config or plan is refused in one line naming what
// differs, a corrupt case file names itself; --resume without --out is
// refused; the same options then finish it.
TEST_F(ClusterCliTest, AResumeOfAnotherRunIsRefusedInOneLine) {
  std::filesystem::copy(KCRIG_TEST_CONFIG_DIR, Path("cfg"),
                        std::filesystem::copy_options::recursive);
  const std::string out = Path("v.json");
  const std::string folder = out + ".checkpoint";
  auto validate = [&](const std::string& options) {
    return std::string(KCRIG_BINARY) + " validate --quiet --config " +
           Path("cfg") + " " + options;
  };
  const std::string same = "--cases 4 --effects none --seed 2";
  const std::string cases = validate(same + " --out " + out);
  const CliResult stopped = SignalWhenKept(cases, folder, 1, "INT");
  EXPECT_NE(stopped.output.find("interrupted (SIGINT); "), std::string::npos)
      << stopped.output;
  EXPECT_NE(stopped.output.find("cases kept in " + folder), std::string::npos)
      << stopped.output;
  ASSERT_GE(KeptItems(folder), 1);
  ASSERT_FALSE(std::filesystem::exists(out));
  const std::pair<std::string, std::string> others[] = {
      {"--cases 4 --effects none --seed 3", "(seed was 2, is 3)"},
      {"--cases 4 --effects rig_compliance --seed 2",
       "(effects was none, is rig_compliance)"},
      {"--cases 5 --effects none --seed 2", "(cases was 4, is 5)"}};
  for (const auto& [options, expected] : others) {
    const CliResult run =
        RunCommand(validate(options + " --resume --out " + out));
    EXPECT_EQ(run.exit_code, 1) << run.output;
    EXPECT_EQ(CountLines(run.output), 1) << run.output;
    EXPECT_NE(run.output.find(expected), std::string::npos) << run.output;
  }
  const std::string model = ReadFile(Path("cfg/model.yaml"));
  WriteFile(Path("cfg/model.yaml"), model + "# edited\n");
  CliResult run = RunCommand(cases + " --resume");
  EXPECT_NE(run.output.find("(config was "), std::string::npos) << run.output;
  WriteFile(Path("cfg/model.yaml"), model);
  WriteFile(folder + "/item-000003.json", "{\"item\": 3, \"seconds\": 1");
  run = RunCommand(cases + " --resume");
  EXPECT_EQ(CountLines(run.output), 1) << run.output;
  EXPECT_NE(run.output.find("item-000003.json: not a checkpoint item"),
            std::string::npos)
      << run.output;
  std::filesystem::remove(folder + "/item-000003.json");
  run = RunKcrig("validate --quiet --cases 4 --resume");
  EXPECT_NE(run.output.find("--resume: needs --out"), std::string::npos)
      << run.output;
  run = RunCommand(cases + " --resume");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const std::string uninterrupted = Path("whole.json");
  const CliResult whole =
      RunCommand(validate(same + " --out " + uninterrupted));
  ASSERT_EQ(whole.exit_code, 0) << whole.output;
  EXPECT_EQ(ReadFile(out), ReadFile(uninterrupted));
}

// A test plan: every case runs its ramps, and validate.json says so.
TEST_F(ClusterCliTest, APlanGivesEveryCaseItsRamps) {
  const std::string plan = Path("plan.yaml");
  WriteFile(
      plan,
      "training:\n"
      "  - {phi_deg: 80, z_a: -0.4, duration: 1.5, hold: 0.2, return: 1}\n"
      "  - {phi_deg: 15, z_a: -0.1, duration: 1.5, hold: 0, return: 1}\n"
      "holdout:\n"
      "  - {phi_deg: 45, z_a: -0.3, duration: 1, hold: 0.1, return: 1}\n");
  const CliResult run = RunKcrig(
      "validate --quiet --cases 2 --effects none,rig_compliance "
      "--plan " +
      plan + " --out " + Path("v.json"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const nlohmann::json doc = nlohmann::json::parse(ReadFile(Path("v.json")));
  const nlohmann::json designs = {
      {"training",
       {"--phi 80.000 --z -0.4000 --duration 1.500 --hold 0.200 --return "
        "1.000",
        "--phi 15.000 --z -0.1000 --duration 1.500 --hold 0.000 --return "
        "1.000"}},
      {"holdout",
       {"--phi 45.000 --z -0.3000 --duration 1.000 --hold 0.100 --return "
        "1.000"}}};
  EXPECT_EQ(doc["plan"], designs);
  for (const nlohmann::json& c : doc["case_results"]) {
    EXPECT_EQ(c["designs"], designs);
  }
}

TEST_F(ClusterCliTest, ABadPlanIsOneLineNamingFileLineAndKey) {
  const std::string plan = Path("plan.yaml");
  const std::string out = Path("v.json");
  const std::pair<std::string, std::string> cases[] = {
      {"training:\n  - {phi_deg: 80, duration: 1, hold: 0, return: 1}\n",
       "plan.yaml:2: training[0].z_a: missing key"},
      {"training:\n  - {phi_deg: 80, z_a: 0, duration: -1, hold: 0, "
       "return: 1}\n",
       "training[0].duration: must be within"},
      {"training: []\n", "training: expected a list of 1 to 32 ramps"},
      {"holdout:\n  - {phi_deg: 1, z_a: 0, duration: 1, hold: 0, return: "
       "1}\n",
       "training: missing key"},
      {"training:\n  - {phi_deg: 80, z_a: 0, duration: 1, hold: 0, return: "
       "1}\nramps: 3\n",
       "ramps: unknown key"},
      // A ramp the rig refuses (8 kN in 0.2 s: faster than rig.yaml's
      // safety.force_rate_max), refused before any case runs.
      {"training:\n  - {phi_deg: 80, z_a: 0, duration: 1, hold: 0, return: "
       "1}\nholdout:\n  - {phi_deg: 80, z_a: 0, duration: 0.2, hold: 0, "
       "return: 1}\n",
       "plan.yaml: holdout[0]: the run would change the force at 40000 N/s, "
       "beyond safety.force_rate_max"}};
  for (const auto& [text, expected] : cases) {
    WriteFile(plan, text);
    const CliResult run =
        RunKcrig("validate --quiet --plan " + plan + " --out " + out);
    EXPECT_EQ(run.exit_code, 1) << text << run.output;
    EXPECT_EQ(CountLines(run.output), 1) << run.output;
    EXPECT_NE(run.output.find(expected), std::string::npos) << run.output;
    EXPECT_FALSE(std::filesystem::exists(out));
    EXPECT_FALSE(std::filesystem::exists(out + ".checkpoint"));
  }
}

TEST_F(ClusterCliTest, BadInputIsOneLineNamingTheOption) {
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
