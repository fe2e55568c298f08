#include "records/run_log.h"

#include <signal.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "records/can_bus_log.h"

namespace kcrig {
namespace {

namespace fs = std::filesystem;

RunLog SmallLog() {
  RunLog log;
  for (int j = 0; j < 3; ++j) {
    LogSample s;
    s.t = 1e-3 * j;
    s.force << -1000.0 + j, 0.1, 0;
    s.y << 1e-5 * j, -2e-6, 3.0000000000000004e-7, 0.1, 0.2, 1.0 / 3.0;
    log.samples.push_back(s);
  }
  log.metadata.rate = 1000;
  log.metadata.transport = "simulation";
  log.metadata.synthetic = true;
  log.metadata.truth_parameters = {{"c_O1", 4.1e6}};
  return log;
}

TEST(RunLogTest, WritesHeaderRoundTripValuesAndSidecar) {
  const fs::path dir = fs::temp_directory_path() / "kcrig_run_log_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string csv = (dir / "run.csv").string();
  ASSERT_TRUE(WriteRunLog(csv, SmallLog()).ok());

  std::ifstream in(csv);
  std::string header, row;
  std::getline(in, header);
  EXPECT_EQ(header, "t,Fx,Fy,Fz,x,y,z,toe,camber,caster");
  std::getline(in, row);
  std::getline(in, row);
  // Shortest round-trip formatting: the value reads back bit for bit.
  std::stringstream fields(row);
  std::string field;
  for (int k = 0; k < 10; ++k) std::getline(fields, field, ',');
  EXPECT_EQ(std::stod(field), 1.0 / 3.0);

  const nlohmann::json sidecar =
      nlohmann::json::parse(std::ifstream(dir / "run.json"));
  EXPECT_EQ(sidecar["units"]["toe"], "rad");
  EXPECT_EQ(sidecar["units"]["x"], "m");
  EXPECT_EQ(sidecar["rate_hz"], 1000.0);
  EXPECT_EQ(sidecar["truth"]["parameters"]["c_O1"], 4.1e6);
  fs::remove_all(dir);
}

TEST(RunLogTest, CommandedForceColumnsFollowTheMeasuredOnes) {
  const fs::path dir = fs::temp_directory_path() / "kcrig_run_log_cmd_test";
  fs::create_directories(dir);
  RunLog log = SmallLog();
  log.has_commanded_force = true;
  ASSERT_TRUE(WriteRunLog((dir / "run.csv").string(), log).ok());
  std::ifstream in(dir / "run.csv");
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "t,Fx,Fy,Fz,x,y,z,toe,camber,caster,Fx_cmd,Fy_cmd,Fz_cmd");
  fs::remove_all(dir);
}

TEST(RunLogTest, PhasesReadBackAndAnUnknownPhaseIsNamed) {
  const fs::path dir = fs::temp_directory_path() / "kcrig_run_log_phase_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  RunLog log = SmallLog();
  log.has_commanded_force = true;
  log.has_loop_columns = true;
  log.metadata.excitation.duration = 1;
  log.metadata.sigma_position = 2e-5;
  log.metadata.sigma_angle = 1e-4;
  const RunPhase phases[3] = {RunPhase::kTare, RunPhase::kRamp,
                              RunPhase::kReturn};
  for (int j = 0; j < 3; ++j) log.samples[j].phase = RunPhaseName(phases[j]);
  const std::string csv = (dir / "run.csv").string();
  ASSERT_TRUE(WriteRunLog(csv, log).ok());
  RunLog read;
  const Status status = ReadRunLog(csv, &read);
  ASSERT_TRUE(status.ok()) << status.message();
  for (int j = 0; j < 3; ++j) {
    EXPECT_EQ(read.samples[j].phase, RunPhaseName(phases[j]));
  }
  std::stringstream text;
  text << std::ifstream(csv).rdbuf();
  std::string edited = text.str();
  edited.replace(edited.find(",ramp,"), 6, ",rampe,");
  std::ofstream(csv) << edited;
  const Status bad = ReadRunLog(csv, &read);
  EXPECT_FALSE(bad.ok());
  EXPECT_NE(bad.message().find("run.csv:3: column 'phase': unknown phase "
                               "'rampe'"),
            std::string::npos)
      << bad.message();
  fs::remove_all(dir);
}

TEST(RunLogTest, FailureLeavesNoFileBehind) {
  const fs::path dir = fs::temp_directory_path() / "kcrig_run_log_fail_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  // The sidecar's path is taken by a directory: the CSV temporary is
  // written, the sidecar's rename fails, and neither file may remain.
  fs::create_directories(dir / "run.json");
  fs::create_directories(dir / "run.json" / "occupied");
  const Status status = WriteRunLog((dir / "run.csv").string(), SmallLog());
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find("run.json"), std::string::npos)
      << status.message();
  EXPECT_FALSE(fs::exists(dir / "run.csv"));
  for (const auto& entry : fs::directory_iterator(dir)) {
    EXPECT_EQ(entry.path().filename(), "run.json") << entry.path();
  }
  fs::remove_all(dir);
}

// A CAN run's bus log the disk refuses (a file-size limit here, as a full
// disk would): the failure is raised for the loop to trip on, said with
// what is kept, and the file ends on a whole line.
TEST(CanBusLogTest, AWriteTheDiskRefusesIsRaisedAndTheFileEndsOnAWholeLine) {
  const fs::path dir = fs::temp_directory_path() / "kcrig_can_bus_log_test";
  fs::remove_all(dir);
  const std::string path = (dir / "can.log").string();
  CanBusLog log;
  ASSERT_TRUE(log.Open(path, "vcan0").ok());
  struct sigaction ignore {};
  ignore.sa_handler = SIG_IGN;
  struct sigaction previous {};
  ASSERT_EQ(sigaction(SIGXFSZ, &ignore, &previous), 0);  // EFBIG instead
  rlimit old_limit{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old_limit), 0);
  rlimit limit = old_limit;
  limit.rlim_cur = 4096;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &limit), 0);
  TimedCanFrame frame;
  frame.frame.id = 0x123;
  frame.frame.dlc = 8;
  for (int k = 0; k < 2000 && !log.write_failed()->load(); ++k) {
    frame.time_us = 1000 * k;
    log.Push(frame);
    if (k % 50 == 49) {
      std::this_thread::sleep_for(std::chrono::milliseconds(25));
    }
  }
  const Status closed = log.Close();
  setrlimit(RLIMIT_FSIZE, &old_limit);
  sigaction(SIGXFSZ, &previous, nullptr);
  EXPECT_TRUE(log.write_failed()->load());
  EXPECT_FALSE(closed.ok());
  EXPECT_NE(log.WriteFailure().find(path + ".partial: File too large; its " +
                                    std::to_string(log.written()) +
                                    " whole frames are kept"),
            std::string::npos)
      << log.WriteFailure();
  std::ifstream in(path + ".partial");
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  ASSERT_FALSE(text.empty());
  EXPECT_LE(text.size(), 4096u);
  EXPECT_EQ(text.back(), '\n');
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), log.written());
  fs::remove_all(dir);
}

TEST(RunLogTest, RejectsNonCsvName) {
  EXPECT_FALSE(WriteRunLog("/tmp/run.txt", SmallLog()).ok());
}

}  // namespace
}  // namespace kcrig
