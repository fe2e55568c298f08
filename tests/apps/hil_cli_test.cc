// The HIL path with real processes: `kcrig emulate` serving Modbus TCP on
// loopback, `kcrig run` as the master, the estimator on the log; peers
// (mbpoll, a pymodbus server); fault injection (emulator killed, frozen,
// travel limit, error detector, SIGTERM) ending in the safe state.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sched.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/support/child_process.h"
#include "tests/support/cli_runner.h"
#include "tests/support/edited_config.h"
#include "tests/support/hil_checks.h"
#include "tests/support/temp_dir_test.h"

namespace kcrig {
namespace {

// The highest CPU this process may run on.
int LastAllowedCpu() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof(set), &set) != 0) return 0;
  int last = 0;
  for (int cpu = 0; cpu < CPU_SETSIZE; ++cpu) {
    if (CPU_ISSET(cpu, &set)) last = cpu;
  }
  return last;
}

// At most the deadlines a loop slept through, from timing.json's wake-up
// histogram: [lower edge us, count] bins at most 10 us wide below 100 ms.
long DeadlinesPassedWhileAsleep(const nlohmann::json& timing) {
  const double period_us = timing["period_us"].get<double>();
  long passed = 0;
  for (const auto& bin : timing["phases"]["wakeup"]["histogram_us"]) {
    const double upper_us = bin[0].get<double>() + 10.0;
    passed += bin[1].get<long>() * static_cast<long>(upper_us / period_us);
  }
  return passed;
}

class HilCliTest : public TempDirTest {
 protected:
  // The controller and the software rig share one CPU, as docs/rig.md
  // advises when both run on one machine: the loopback reply then wakes
  // the loop without a cross-CPU wake-up, which a VM makes slow.
  void SetUp() override {
    TempDirTest::SetUp();
    const std::string pinned = "cpu: " + std::to_string(LastAllowedCpu());
    EditedConfig("rig.yaml", "cpu: -1", pinned);
    config_ = EditedConfig("plant.yaml", "cpu: -1", pinned);
  }

  // Starts `kcrig emulate` on a free loopback port; returns the port.
  int StartEmulator(const std::vector<std::string>& extra = {},
                    const std::string& config = "") {
    std::vector<std::string> argv = {
        KCRIG_BINARY,   "emulate",
        "--config",     config.empty() ? config_ : config,
        "--modbus-tcp", "127.0.0.1:0"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    // Each emulator its own output file: a second one's port is never read
    // from the first one's lines.
    emulator_ = std::make_unique<ChildProcess>(
        argv, Path("emulate" + std::to_string(++emulators_) + ".out"));
    const std::string port = emulator_->WaitForOutput(
        "serving modbus-tcp://127\\.0\\.0\\.1:([0-9]+)");
    EXPECT_FALSE(port.empty()) << emulator_->Output();
    return port.empty() ? 0 : std::stoi(port);
  }

  std::unique_ptr<ChildProcess> StartRun(
      int port, const std::string& log_dir,
      const std::vector<std::string>& extra = {},
      const std::string& config = "") {
    std::vector<std::string> argv = {
        KCRIG_BINARY, "run",
        "--config",   config.empty() ? config_ : config,
        "--rig",      "modbus-tcp://127.0.0.1:" + std::to_string(port),
        "--log-dir",  log_dir,
        "--quiet"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    return std::make_unique<ChildProcess>(argv, Path("run.out"));
  }

  // The source config with one edit, in this test's directory.
  std::string EditedConfig(const std::string& file, const std::string& from,
                           const std::string& to) {
    return EditConfig(Path("config"), file, from, to);
  }

  // For the pymodbus peer: Python serves slower than the 1 ms loop allows,
  // so the loop runs at 100 Hz; its plant is not the suspension, so no
  // error detector against the model.
  std::string PymodbusRigConfig() {
    EditedConfig("rig.yaml", "period: 0.001", "period: 0.01");
    EditedConfig("rig.yaml", "response_timeout: 0.0004",
                 "response_timeout: 0.004");
    EditedConfig("rig.yaml", "error_position_max: 0.002",
                 "error_position_max: 0.1");
    return EditedConfig("rig.yaml", "error_angle_max_deg: 0.5",
                        "error_angle_max_deg: 5.0");
  }

  std::string config_;  // config/ with both processes pinned to one CPU
  std::unique_ptr<ChildProcess> emulator_;
  int emulators_ = 0;  // started so far
};

TEST_F(HilCliTest, FullRampLogsEveryCycleAndTheEstimateFindsTheTruePlant) {
  const int port = StartEmulator();
  const std::string log_dir = Path("run");
  auto run = StartRun(port, log_dir);
  ASSERT_EQ(run->Wait(), 0) << run->Output();
  const nlohmann::json sidecar = ReadJson(log_dir + "/run.json");
  const nlohmann::json& hil = sidecar["hil"];
  // Streamed to run.csv.partial during the run, renamed at the end.
  EXPECT_FALSE(std::filesystem::exists(log_dir + "/run.csv.partial"));
  const Csv csv = ReadCsv(log_dir + "/run.csv");
  // 0.2 + 1.0 + 0.5 + 4.0 + 1.0 s at 1 kHz: every cycle is a row.
  ASSERT_EQ(csv.rows.size(), 6700u);
  EXPECT_EQ(hil["cycles"].get<long>() + hil["skipped_cycles"].get<long>(),
            6700);
  for (size_t j = 0; j < csv.rows.size(); ++j) {
    ASSERT_NEAR(csv.Value(j, "t"), j * 1e-3, 1e-9);
  }
  // Each row without a fresh sample is counted as a read error, a stale
  // sample or a cycle skipped by an overrun. Those the controller and the
  // rig cause are rare on loopback. Cycles skipped because the machine woke
  // the loop late (a shared VM preempts it for milliseconds) are the host's:
  // each is explained by a wake-up latency timing.json measured.
  long without = 0;
  for (const auto& row : csv.rows) without += row[csv.Column("fresh")] == "0";
  EXPECT_EQ(without, hil["rows_without_fresh_sample"].get<long>());
  EXPECT_EQ(without, hil["read_errors"].get<long>() +
                         hil["stale_samples"].get<long>() +
                         hil["skipped_cycles"].get<long>());
  const long late = hil["skipped_by_late_wakeup"].get<long>();
  EXPECT_LT(without - late, 67)
      << "more than 1 % of the samples lost to the controller or the rig";
  const nlohmann::json timing = ReadJson(log_dir + "/timing.json");
  EXPECT_EQ(timing["skipped_by_late_wakeup"].get<long>(), late);
  EXPECT_LE(late, DeadlinesPassedWhileAsleep(timing));
  EXPECT_LT(late, 670) << "the loop ran late for more than 10 % of the run";
  std::printf(
      "HIL run: %ld of 6700 rows without a fresh sample, %ld of them "
      "skipped by late wake-ups\n",
      without, late);
  for (const char* column :
       {"Fx", "Fx_cmd", "x_model", "phase", "rig_sample"}) {
    EXPECT_GE(csv.Column(column), 0) << column;
  }

  // The estimator recovers plant.yaml's stiffnesses within 3.3 standard
  // errors (0.1 % two-sided each).
  const CliResult estimate =
      RunKcrig("estimate --config " + std::string(KCRIG_TEST_CONFIG_DIR) +
               " --log " + log_dir + "/run.csv --out " + Path("est.json"));
  ASSERT_EQ(estimate.exit_code, 0) << estimate.output;
  const nlohmann::json est = ReadJson(Path("est.json"));
  const std::map<std::string, double> truth = {{"c_O1", 3.6e6},
                                               {"c_O2", 4.4e6},
                                               {"c_V1", 3.9e6},
                                               {"c_V2", 4.25e6},
                                               {"c_P", 3.75e6}};
  for (const auto& p : est["parameters"]) {
    const double value = p["value"], se = p["standard_error"];
    EXPECT_LT(std::abs(value - truth.at(p["name"])), 3.3 * se)
        << p["name"] << " " << value;
  }
  EXPECT_LT(est["sigma_hat"].get<double>(), 1.2);
  // timing.json has every phase.
  for (const char* phase : {"wakeup", "read", "compute", "write", "cycle"}) {
    EXPECT_EQ(timing["phases"][phase]["count"].get<long>(),
              hil["cycles"].get<long>())
        << phase;
  }
}

// Issue #7 through the real HIL path: three runs (ramp, hold and return
// ramp; two for training, one held out) against an emulator whose clamped
// body has compliant mounts, then `kcrig diagnose` on the run logs.
TEST_F(HilCliTest, DiagnoseAttributesTheEmulatorsEffectFromRunLogs) {
  const int port = StartEmulator({"--effect", "rig_compliance:k=2e7"});
  const std::vector<std::vector<std::string>> designs = {
      {"--phi", "80", "--z", "-0.4", "--duration", "1.5", "--hold", "0.2",
       "--return", "1"},
      {"--phi", "20", "--z", "-0.1", "--duration", "1", "--hold", "0.2",
       "--return", "1.5"},
      {"--phi", "50", "--z", "-0.25", "--duration", "2", "--hold", "0.3",
       "--return", "1"}};
  for (size_t i = 0; i < designs.size(); ++i) {
    auto run = StartRun(port, Path("run" + std::to_string(i)), designs[i]);
    ASSERT_EQ(run->Wait(), 0) << run->Output();
  }
  const CliResult diagnose = RunKcrig(
      "diagnose --config " + std::string(KCRIG_TEST_CONFIG_DIR) + " --log " +
      Path("run0/run.csv") + " --log " + Path("run1/run.csv") + " --holdout " +
      Path("run2/run.csv") + " --out " + Path("diag.json"));
  ASSERT_EQ(diagnose.exit_code, 0) << diagnose.output;
  std::printf("%s", diagnose.output.c_str());
  const nlohmann::json diag = ReadJson(Path("diag.json"));
  EXPECT_EQ(diag["verdict"], "rig_compliance") << diagnose.output;
  const nlohmann::json& q = diag["quantification"];
  EXPECT_GE(q["gap_closed"].get<double>(), 0.8);
  for (const auto& p : q["effect_parameters"]) {
    // 1/k = 5e-8 m/N within its 95 % interval, widened by 10 % for the
    // emulator's finer integration step.
    EXPECT_LT(p["ci95"][0].get<double>(), 5.5e-8) << p;
    EXPECT_GT(p["ci95"][1].get<double>(), 4.5e-8) << p;
  }
}

TEST_F(HilCliTest, CampaignRunsItsExperimentsOnTheEmulatedRig) {
  const int port = StartEmulator();
  const CliResult r =
      RunKcrig("campaign --config " + config_ +
               " --rig modbus-tcp://127.0.0.1:" + std::to_string(port) +
               " --iterations 1 --budget 30 --quiet --out " + Path("campaign"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* run : {"iteration_0", "iteration_1"}) {
    const std::string dir = Path("campaign") + "/" + run;
    const nlohmann::json sidecar = ReadJson(dir + "/run.json");
    EXPECT_TRUE(sidecar["hil"]["completed"]) << run;
    EXPECT_EQ(sidecar["transport"],
              "modbus-tcp://127.0.0.1:" + std::to_string(port));
    EXPECT_TRUE(std::filesystem::exists(dir + "/timing.json")) << run;
  }
  // The report shows the rig runs' loop timing beside the campaign.
  EXPECT_TRUE(std::filesystem::exists(Path("campaign/report.html")));
  EXPECT_NE(r.output.find("report with"), std::string::npos) << r.output;
  // The second experiment is the designed one.
  const nlohmann::json first = ReadJson(Path("campaign/iteration_0/run.json"));
  const nlohmann::json second = ReadJson(Path("campaign/iteration_1/run.json"));
  EXPECT_NE(first["excitation"]["phi_rad"], second["excitation"]["phi_rad"]);
  EXPECT_TRUE(std::filesystem::exists(Path("campaign/campaign.json")));
}

// Issue #47's reproduction over Modbus: one worn bushing in the emulator,
// whose state carries over between the campaign's runs (the next tares sit
// off the first). The campaign adopts the effect, stays adequate in every
// later iteration and exits 0, each stiffness's interval covering the
// plant's value.
TEST_F(HilCliTest, AWornBushingStaysAdoptedOverModbusThoughTheRigRemembers) {
  const int port =
      StartEmulator({"--effect", "hysteresis:force=300,at=bushing:O2"});
  const CliResult r =
      RunKcrig("campaign --config " + config_ +
               " --rig modbus-tcp://127.0.0.1:" + std::to_string(port) +
               " --quiet --no-report --out " + Path("campaign"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json doc = ReadJson(Path("campaign/campaign.json"));
  ASSERT_EQ(doc["iterations"].size(), 4u);
  const double truth[] = {3.6e6, 4.4e6, 3.9e6, 4.25e6, 3.75e6};
  const double first_tare =
      ReadJson(Path("campaign/iteration_0/run.json"))["hil"]["rest_pose"][0];
  for (int k = 1; k < 4; ++k) {
    const nlohmann::json& it = doc["iterations"][k];
    EXPECT_EQ(it["model"], "hysteresis@bushing:O2") << k;
    EXPECT_EQ(it["adequacy"]["verdict"], "adequate") << k << it["adequacy"];
    const nlohmann::json run =
        ReadJson(Path("campaign/iteration_" + std::to_string(k) + "/run.json"));
    EXPECT_GT(std::abs(run["hil"]["rest_pose"][0].get<double>() - first_tare),
              20e-6)
        << k;
    for (int i = 0; i < 5; ++i) {
      const nlohmann::json& p = it["parameters"][i];
      EXPECT_LE(p["ci95"][0].get<double>(), truth[i]) << k << p;
      EXPECT_GE(p["ci95"][1].get<double>(), truth[i]) << k << p;
    }
  }
}

// The embedded SIL rig and a Modbus run of the same experiment and plant:
// the same columns and phases, and estimates that agree within their
// intervals.
TEST_F(HilCliTest, TheSilRigLogsWhatTheModbusPathLogs) {
  const int port = StartEmulator();
  auto run = StartRun(port, Path("modbus"));
  ASSERT_EQ(run->Wait(), 0) << run->Output();
  const CliResult sil = RunKcrig("run --config " + config_ +
                                 " --rig sim --quiet --log-dir " + Path("sil"));
  ASSERT_EQ(sil.exit_code, 0) << sil.output;
  const Csv modbus_csv = ReadCsv(Path("modbus/run.csv"));
  const Csv sil_csv = ReadCsv(Path("sil/run.csv"));
  EXPECT_EQ(modbus_csv.header, sil_csv.header);
  ASSERT_EQ(modbus_csv.rows.size(), sil_csv.rows.size());
  const int phase = sil_csv.Column("phase");
  for (size_t j = 0; j < sil_csv.rows.size(); ++j) {
    ASSERT_EQ(modbus_csv.rows[j][phase], sil_csv.rows[j][phase]) << j;
  }
  const nlohmann::json sil_json = ReadJson(Path("sil/run.json"));
  const nlohmann::json modbus_json = ReadJson(Path("modbus/run.json"));
  for (const auto& [key, value] : modbus_json["hil"].items()) {
    EXPECT_TRUE(sil_json["hil"].contains(key)) << key;
  }
  nlohmann::json estimates[2];
  for (int k = 0; k < 2; ++k) {
    const std::string log = Path(k == 0 ? "modbus" : "sil");
    const CliResult e = RunKcrig("estimate --config " + config_ + " --log " +
                                 log + "/run.csv --out " + log + "/est.json");
    ASSERT_EQ(e.exit_code, 0) << e.output;
    estimates[k] = ReadJson(log + "/est.json");
    EXPECT_EQ(estimates[k]["rig_memory_rows"][0], 1200);
  }
  for (int i = 0; i < 5; ++i) {
    const nlohmann::json& a = estimates[0]["parameters"][i];
    const nlohmann::json& b = estimates[1]["parameters"][i];
    const double difference =
        a["value"].get<double>() - b["value"].get<double>();
    const double se = std::hypot(a["standard_error"].get<double>(),
                                 b["standard_error"].get<double>());
    EXPECT_LT(std::abs(difference), 3 * se) << a["name"];
  }
}

TEST_F(HilCliTest, MbpollReadsTheDocumentedRegistersAndTheRigProtectsItself) {
  const int port = StartEmulator();
  const std::string target = "-p " + std::to_string(port) + " 127.0.0.1";
  // Input registers 0..5: status 0 (disabled), fault 0, sample (2 words),
  // sequence echo 0, protocol 3.
  CliResult r = RunCommand("mbpoll -m tcp -a 1 -0 -1 -t 3 -r 0 -c 6 " + target);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("[0]: \t0"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("[5]: \t3"), std::string::npos) << r.output;
  // Load cell and pose as float32, high word first (-B): at rest, near 0.
  r = RunCommand("mbpoll -m tcp -a 1 -0 -1 -t 3:float -B -r 6 -c 9 " + target);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  int values = 0;
  for (const std::string& line : Split(r.output, '\n')) {
    const size_t colon = line.find("]: ");
    if (line.rfind("[", 0) != 0 || colon == std::string::npos) continue;
    const double value = std::stod(line.substr(colon + 3));
    const int address = std::stoi(line.substr(1));
    EXPECT_LT(std::abs(value), address < 12 ? 5.0 : 2e-4) << line;
    ++values;
  }
  EXPECT_EQ(values, 9) << r.output;
  // Enable without a claim: refused (exception 6, server busy), counted.
  r = RunCommand("mbpoll -m tcp -a 1 -0 -1 -t 4 -r 0 " + target + " 1");
  EXPECT_NE(r.output.find("busy"), std::string::npos) << r.output;
  r = RunCommand("mbpoll -m tcp -a 1 -0 -1 -t 3 -r 25 " + target);
  EXPECT_NE(r.output.find("[25]: \t1"), std::string::npos) << r.output;
  // Claim with session 0x1234 and enable at Fx = 500 N, z_a = -0.45 m in
  // one write of registers 0..10 (float32 as two words, high word first).
  // mbpoll then hangs up: the owner's connection closed with the rig
  // enabled, so the rig faults (status fault, fault code 4, owner lost),
  // ramps the force to zero and ends the claim.
  r = RunCommand("mbpoll -m tcp -a 1 -0 -1 -t 4 -r 0 " + target +
                 " 5 1 17402 0 0 0 0 0 48870 26214 4660");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  r = RunCommand("mbpoll -m tcp -a 1 -0 -1 -t 3 -r 0 -c 2 " + target);
  EXPECT_NE(r.output.find("[0]: \t2"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("[1]: \t4"), std::string::npos) << r.output;
  r = RunCommand("mbpoll -m tcp -a 1 -0 -1 -t 3 -r 24 " + target);
  EXPECT_NE(r.output.find("[24]: \t0"), std::string::npos) << r.output;
  r = RunCommand("mbpoll -m tcp -a 1 -0 -1 -t 3:float -B -r 6 -c 1 " + target);
  const size_t colon = r.output.find("[6]: ");
  ASSERT_NE(colon, std::string::npos) << r.output;
  EXPECT_LT(std::abs(std::stod(r.output.substr(colon + 5))), 5.0);
}

TEST_F(HilCliTest, RunsARampAgainstAPymodbusRig) {
  const std::string config = PymodbusRigConfig();
  ChildProcess server(
      {"/usr/bin/python3", KCRIG_TEST_PEERS_DIR "/pymodbus_rig.py",
       config + "/modbus_map.yaml"},
      Path("pymodbus.out"));
  const std::string port = server.WaitForOutput("listening on ([0-9]+)\n", 20);
  ASSERT_FALSE(port.empty()) << server.Output();
  const std::string log_dir = Path("run");
  auto run = StartRun(std::stoi(port), log_dir, {"--duration", "2"}, config);
  ASSERT_EQ(run->Wait(), 0) << run->Output() << server.Output();
  const Csv csv = ReadCsv(log_dir + "/run.csv");
  ASSERT_EQ(csv.rows.size(), 470u);  // (0.2 + 1 + 0.5 + 2 + 1) s at 100 Hz
  // The Python rig is a linear spring per axis: x = Fx / 2e6 etc., its load
  // cell reads the set-point it last received.
  int fresh = 0;
  for (size_t j = 1; j < csv.rows.size(); ++j) {
    if (csv.rows[j][csv.Column("fresh")] != "1") continue;
    ++fresh;
    EXPECT_NEAR(csv.Value(j, "x"), csv.Value(j, "Fx") / 2e6, 1e-9);
    EXPECT_NEAR(csv.Value(j, "y"), csv.Value(j, "Fy") / 2e6, 1e-9);
    EXPECT_NEAR(csv.Value(j, "Fy"), csv.Value(j - 1, "Fy_cmd"), 0.01);
  }
  EXPECT_GT(fresh, 450);
  // The peer saw kcrig's command sequence and acting height.
  const nlohmann::json sidecar = ReadJson(log_dir + "/run.json");
  EXPECT_TRUE(sidecar["hil"]["completed"]);
  EXPECT_NE(server.Output().find("z_a=-0.45"), std::string::npos)
      << server.Output();
}

TEST_F(HilCliTest, EmulatorKilledMidRunTripsTheWatchdog) {
  const int port = StartEmulator();
  const std::string log_dir = Path("run");
  auto run = StartRun(port, log_dir);
  std::this_thread::sleep_for(std::chrono::milliseconds(3000));
  emulator_->Signal(SIGKILL);
  const int code = run->Wait();
  ExpectSafeStop(code, log_dir, "watchdog", run->Output());
  // The ramp-down was commanded into a dead link: said as it was.
  EXPECT_NE(run->Output().find("none of it reached the rig"), std::string::npos)
      << run->Output();
}

TEST_F(HilCliTest, FrozenEmulatorTripsTheWatchdog) {
  const int port = StartEmulator();
  const std::string log_dir = Path("run");
  auto run = StartRun(port, log_dir);
  std::this_thread::sleep_for(std::chrono::milliseconds(3000));
  emulator_->Signal(SIGSTOP);
  const int code = run->Wait();
  emulator_->Signal(SIGCONT);
  ExpectSafeStop(code, log_dir, "watchdog", run->Output());
}

TEST_F(HilCliTest, MeasurementBeyondTravelTripsTheTravelLimit) {
  const std::string config =
      EditedConfig("rig.yaml", "travel_max: 0.05", "travel_max: 0.0008");
  const int port = StartEmulator({}, config);
  const std::string log_dir = Path("run");
  auto run = StartRun(port, log_dir, {}, config);
  const int code = run->Wait();
  ExpectSafeStop(code, log_dir, "travel_limit", run->Output());
}

TEST_F(HilCliTest, RigFarFromTheModelTripsTheErrorDetector) {
  // A soft rig mount: 4 kN give 2.7 mm more than the model predicts.
  const int port = StartEmulator({"--effect", "rig_compliance:k=1.5e6"});
  const std::string log_dir = Path("run");
  auto run = StartRun(port, log_dir);
  const int code = run->Wait();
  ExpectSafeStop(code, log_dir, "error_detector", run->Output());
}

// A second master writes "enable, Fz = 2 kN" into the rig as fast as it
// can while kcrig runs, and a second `kcrig run` starts: the rig (claimed
// by the first run's session) refuses every write of the rogue, the second
// run is refused at activation in one line, and the first run completes
// with the load cell on its command. After the run (claim released) the
// rogue still cannot enable the rig without a claim.
TEST_F(HilCliTest, TheRigObeysOneMaster) {
  const int port = StartEmulator();
  const std::string log_dir = Path("run");
  auto run = StartRun(port, log_dir);
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  auto rogue = [&](const char* seconds, const std::string& out) {
    return std::make_unique<ChildProcess>(
        std::vector<std::string>{"/usr/bin/python3",
                                 KCRIG_TEST_PEERS_DIR "/rogue_master.py",
                                 std::to_string(port), "2000", seconds},
        Path(out));
  };
  auto during = rogue("2", "rogue.out");
  const CliResult second =
      RunKcrig("run --config " + config_ + " --rig modbus-tcp://127.0.0.1:" +
               std::to_string(port) + " --log-dir " + Path("second"));
  EXPECT_EQ(second.exit_code, 1) << second.output;
  EXPECT_NE(second.output.find("is in control (another master)"),
            std::string::npos)
      << second.output;
  EXPECT_EQ(CountLines(second.output), 1) << second.output;
  EXPECT_FALSE(std::filesystem::exists(Path("second/run.csv")));
  during->Wait();
  ASSERT_EQ(run->Wait(), 0) << run->Output() << during->Output();
  EXPECT_NE(during->Output().find("rogue wrote 0 commands"), std::string::npos)
      << during->Output();
  EXPECT_EQ(during->Output().find(", 0 refused"), std::string::npos)
      << during->Output();
  // Fz is never commanded (phi lies in the x-y plane): 2 kN would show.
  const Csv csv = ReadCsv(log_dir + "/run.csv");
  for (size_t j = 0; j < csv.rows.size(); ++j) {
    ASSERT_LT(std::abs(csv.Value(j, "Fz")), 100.0) << "row " << j;
  }
  auto after = rogue("0.5", "rogue_after.out");
  after->Wait();
  EXPECT_NE(after->Output().find("rogue wrote 0 commands"), std::string::npos)
      << after->Output();
  const CliResult status = RunCommand("mbpoll -m tcp -a 1 -0 -1 -t 3 -r 0 -p " +
                                      std::to_string(port) + " 127.0.0.1");
  EXPECT_NE(status.output.find("[0]: \t0"), std::string::npos) << status.output;
}

// A hostile client during a run: it reads every register (the owner's
// token included, were it shown) and forges commands with what it read,
// with echoed and next sequences, claims and releases, by every write
// function. The rig obeys none of it (the claim is bound to the
// controller's connection), the run completes untouched and run.json
// counts the refusals.
TEST_F(HilCliTest, TheRigObeysNoImpostorThatReadsItsRegisters) {
  const int port = StartEmulator();
  const std::string log_dir = Path("run");
  auto run = StartRun(port, log_dir);
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  ChildProcess hostile(
      {"/usr/bin/python3", KCRIG_TEST_PEERS_DIR "/hostile_master.py",
       std::to_string(port), "spoof", "2"},
      Path("hostile.out"));
  hostile.Wait();
  ASSERT_EQ(run->Wait(), 0) << run->Output() << hostile.Output();
  EXPECT_NE(hostile.Output().find(" 0 writes obeyed"), std::string::npos)
      << hostile.Output();
  // Fz is never commanded (phi lies in the x-y plane): the forged 4 kN
  // would show; no axis beyond force_max (5 kN).
  const Csv csv = ReadCsv(log_dir + "/run.csv");
  for (size_t j = 0; j < csv.rows.size(); ++j) {
    ASSERT_LT(std::abs(csv.Value(j, "Fz")), 100.0) << "row " << j;
    for (const char* axis : {"Fx", "Fy"}) {
      ASSERT_LE(std::abs(csv.Value(j, axis)), 5000.0) << "row " << j;
    }
  }
  const nlohmann::json sidecar = ReadJson(log_dir + "/run.json");
  EXPECT_GT(sidecar["hil"]["transport"]["refused_writes"].get<int>(), 100)
      << sidecar["hil"].dump();
}

// With no controller, a client that claims the rig is its master: the rig
// still holds its own limits whatever it writes (1e9 N, NaN, inf): no
// force beyond its force_max (5 kN, plant.yaml) but the load cell's noise
// (0.5 N, five sigma allowed), no travel beyond its travel_max (60 mm).
TEST_F(HilCliTest, TheRigHoldsItsOwnLimitsWhateverItsMasterWrites) {
  const int port = StartEmulator();
  ChildProcess hostile(
      {"/usr/bin/python3", KCRIG_TEST_PEERS_DIR "/hostile_master.py",
       std::to_string(port), "claim", "1.5"},
      Path("hostile.out"));
  ASSERT_EQ(hostile.Wait(), 0) << hostile.Output();
  const std::string out = hostile.Output();
  const size_t force_at = out.find("max |F| read ");
  const size_t travel_at = out.find("max |xyz| read ");
  ASSERT_NE(force_at, std::string::npos) << out;
  ASSERT_NE(travel_at, std::string::npos) << out;
  EXPECT_GT(std::stod(out.substr(force_at + 13)), 4900.0) << out;
  EXPECT_LE(std::stod(out.substr(force_at + 13)), 5002.5) << out;
  EXPECT_LE(std::stod(out.substr(travel_at + 15)), 0.06 + 0.005) << out;
  EXPECT_EQ(out.find(" 0 writes obeyed"), std::string::npos) << out;
}

// Idle connections (a crashed HMI, a scan, 16 or 200 of them) do not lock
// the master out: the rig closes the longest idle for it, says so, and the
// run completes.
TEST_F(HilCliTest, IdleConnectionsDoNotLockTheMasterOut) {
  const int port = StartEmulator();
  std::vector<int> idle;
  for (int k = 0; k < 200; ++k) {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<std::uint16_t>(port));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(
        connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)), 0);
    idle.push_back(fd);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(2000));
  const CliResult run =
      RunKcrig("run --config " + config_ +
               " --rig modbus-tcp://127.0.0.1:" + std::to_string(port) +
               " --log-dir " + Path("run") + " --duration 1 --quiet");
  EXPECT_EQ(run.exit_code, 0) << run.output;
  for (int fd : idle) close(fd);
  EXPECT_NE(emulator_->Output().find("(the most it serves): closed client"),
            std::string::npos)
      << emulator_->Output();
}

// A stall of the controller longer than the rig's command timeout (50 ms)
// but shorter than its claim timeout: the rig faults itself; the trip names
// its watchdog, not a second master, and the ramp-down still reaches the
// rig (the claim stayed with this controller).
TEST_F(HilCliTest, AStallIsNamedAsTheRigsWatchdogAndTheClaimStays) {
  const int port = StartEmulator();
  const std::string log_dir = Path("run");
  auto run = StartRun(port, log_dir);
  std::this_thread::sleep_for(std::chrono::milliseconds(3000));
  run->Signal(SIGSTOP);
  std::this_thread::sleep_for(std::chrono::milliseconds(150));
  run->Signal(SIGCONT);
  const int code = run->Wait();
  EXPECT_EQ(code, 3) << run->Output();
  EXPECT_NE(run->Output().find("tripped: rig_fault (the rig reported fault 2: "
                               "its command watchdog"),
            std::string::npos)
      << run->Output();
  EXPECT_EQ(run->Output().find("master"), std::string::npos) << run->Output();
  const nlohmann::json hil = ReadJson(log_dir + "/run.json")["hil"];
  EXPECT_GT(hil["commands_after_trip"].get<long>(), 100) << hil.dump();
  EXPECT_EQ(hil["undelivered_after_trip"], 0) << hil.dump();
}

// The fault-reaction matrix's Modbus TCP rows (docs/rig.md, safety): an
// operator stop, the rig's own emergency stop (SIGUSR1 to kcrig emulate) and a
// travel limit reached, each timed from run.csv in cycles from the trip:
// every axis of the load cell below 5 % of force_max, and the disable.
// Within the loop's ramp-down (500 cycles) and the actuator's lag.
TEST_F(HilCliTest, FaultReactionsOverModbusAreTimedFromTheLog) {
  auto timed = [&](const std::string& name, const std::string& log_dir,
                   const std::string& cause) {
    const nlohmann::json sidecar = ReadJson(log_dir + "/run.json");
    EXPECT_EQ(sidecar["hil"]["safety"]["cause"], cause) << name;
    const Csv csv = ReadCsv(log_dir + "/run.csv");
    const auto trip = static_cast<size_t>(std::lround(
        sidecar["hil"]["safety"]["trip_time_s"].get<double>() / 1e-3));
    long low = -1, off = -1;
    for (size_t j = trip; j < csv.rows.size(); ++j) {
      const double force =
          std::max({std::abs(csv.Value(j, "Fx")), std::abs(csv.Value(j, "Fy")),
                    std::abs(csv.Value(j, "Fz"))});
      if (low < 0 && force < 0.05 * 5000) low = static_cast<long>(j - trip);
      if (off < 0 && csv.rows[j][csv.Column("safety")] == "2") {
        off = static_cast<long>(j - trip);
      }
    }
    std::printf("| %s (Modbus TCP) | %s | 0 | | %ld | %ld |\n", name.c_str(),
                cause.c_str(), low, off);
    EXPECT_GE(low, 0) << name;
    EXPECT_LE(low, 510) << name;
    EXPECT_GE(off, 0) << name;
    EXPECT_LE(off, 502) << name;
  };
  int port = StartEmulator();
  auto run = StartRun(port, Path("stop"));
  std::this_thread::sleep_for(std::chrono::milliseconds(3000));
  run->Signal(SIGINT);
  EXPECT_EQ(run->Wait(), 3) << run->Output();
  timed("operator stop (SIGINT)", Path("stop"), "signal");

  run = StartRun(port, Path("estop"));
  std::this_thread::sleep_for(std::chrono::milliseconds(3000));
  emulator_->Signal(SIGUSR1);
  EXPECT_EQ(run->Wait(), 3) << run->Output();
  EXPECT_NE(run->Output().find("fault 5: its emergency stop"),
            std::string::npos)
      << run->Output();
  timed("rig-side fault (its e-stop)", Path("estop"), "rig_fault");

  const std::string config =
      EditedConfig("rig.yaml", "travel_max: 0.05", "travel_max: 0.0008");
  port = StartEmulator({}, config);
  run = StartRun(port, Path("limit"), {}, config);
  EXPECT_EQ(run->Wait(), 3) << run->Output();
  timed("limit reached (travel 0.8 mm)", Path("limit"), "travel_limit");
}

// Modbus RTU over a pseudo-terminal pair (socat): the emulator serves RTU
// on one end and kcrig runs on the other, at a period that fits the wire
// time at 115200 baud (a cycle's read and write take about 10 ms there); a
// 1 kHz loop is refused in one line before the line is opened.
TEST_F(HilCliTest, ModbusRtuOverAPseudoTerminalPair) {
  const std::string rig_tty = Path("rig.tty"), kcrig_tty = Path("kcrig.tty");
  ChildProcess socat({"/usr/bin/socat", "pty,raw,echo=0,link=" + rig_tty,
                      "pty,raw,echo=0,link=" + kcrig_tty},
                     Path("socat.out"));
  for (int k = 0; k < 500 && !(std::filesystem::exists(rig_tty) &&
                               std::filesystem::exists(kcrig_tty));
       ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_TRUE(std::filesystem::exists(kcrig_tty)) << socat.Output();
  const std::string rig = "modbus-rtu://" + kcrig_tty;
  const CliResult fast = RunKcrig("run --config " + config_ + " --rig " + rig +
                                  " --log-dir " + Path("fast"));
  EXPECT_EQ(fast.exit_code, 1) << fast.output;
  EXPECT_NE(fast.output.find("at 115200 baud one cycle's read and write take "
                             "10.24 ms on the wire, more than loop.period "
                             "(1.00 ms)"),
            std::string::npos)
      << fast.output;
  EXPECT_EQ(CountLines(fast.output), 1) << fast.output;

  EditedConfig("rig.yaml", "period: 0.001", "period: 0.02");
  // At 50 Hz the command leads the load cell by 20 kN/s x 2 cycles = 800 N.
  EditedConfig("rig.yaml", "force_error_max: 500.0", "force_error_max: 1500.0");
  const std::string config = EditedConfig(
      "rig.yaml", "response_timeout: 0.0004", "response_timeout: 0.009");
  ChildProcess emulator(
      {KCRIG_BINARY, "emulate", "--config", config, "--modbus-rtu", rig_tty},
      Path("emulate.out"));
  ASSERT_FALSE(
      emulator.WaitForOutput("serving modbus-rtu://" + rig_tty).empty())
      << emulator.Output();
  const std::string log_dir = Path("run");
  ChildProcess run({KCRIG_BINARY, "run", "--config", config, "--rig", rig,
                    "--log-dir", log_dir, "--quiet"},
                   Path("run.out"));
  ASSERT_EQ(run.Wait(), 0) << run.Output() << emulator.Output();
  const nlohmann::json sidecar = ReadJson(log_dir + "/run.json");
  EXPECT_EQ(sidecar["transport"], rig);
  const nlohmann::json& hil = sidecar["hil"];
  // 6.7 s at 50 Hz: every cycle a row, nearly all with a fresh sample.
  const Csv csv = ReadCsv(log_dir + "/run.csv");
  ASSERT_EQ(csv.rows.size(), 335u);
  EXPECT_EQ(hil["cycles"].get<long>() + hil["skipped_cycles"].get<long>(), 335);
  EXPECT_GE(hil["fresh_samples"].get<long>(), 320) << hil.dump();
  EXPECT_EQ(hil["rig_sample_jumps"], 0) << hil.dump();
}

// A rig front end that reports ownership but does not enforce it (the
// pymodbus peer) obeys the rogue: kcrig sees its own sequence echo replaced
// by one it never sent and trips at once, naming the cause.
TEST_F(HilCliTest, ARigObeyingASecondMasterTripsTheEchoCheck) {
  const std::string config = PymodbusRigConfig();
  ChildProcess server(
      {"/usr/bin/python3", KCRIG_TEST_PEERS_DIR "/pymodbus_rig.py",
       config + "/modbus_map.yaml"},
      Path("pymodbus.out"));
  const std::string port = server.WaitForOutput("listening on ([0-9]+)\n", 20);
  ASSERT_FALSE(port.empty()) << server.Output();
  const std::string log_dir = Path("run");
  auto run = StartRun(std::stoi(port), log_dir, {"--duration", "2"}, config);
  std::this_thread::sleep_for(std::chrono::milliseconds(2000));
  ChildProcess rogue(
      {"/usr/bin/python3", KCRIG_TEST_PEERS_DIR "/rogue_master.py", port,
       "2000", "1"},
      Path("rogue.out"));
  const int code = run->Wait();
  rogue.Wait();
  EXPECT_EQ(code, 3) << run->Output();
  EXPECT_NE(run->Output().find("tripped: foreign_master (the rig obeys "
                               "another master: it echoes command sequence"),
            std::string::npos)
      << run->Output();
  const nlohmann::json sidecar = ReadJson(log_dir + "/run.json");
  EXPECT_EQ(sidecar["hil"]["safety"]["cause"], "foreign_master");
  const Csv csv = ReadCsv(log_dir + "/run.csv");
  EXPECT_EQ(csv.rows.back()[csv.Column("safety")], "2");
}

// The disk refuses the log mid-run (here a file-size limit, EFBIG, as a
// full disk gives ENOSPC): the run trips and ramps down, the rows that
// reached the disk stay in run.csv.partial ending on a whole row, and the
// sidecar says how many and why.
TEST_F(HilCliTest, ALogTheDiskRefusesTripsTheRunAndKeepsWholeRows) {
  const int port = StartEmulator();
  const std::string log_dir = Path("run");
  ChildProcess run(
      {"/usr/bin/prlimit", "--fsize=1000000", KCRIG_BINARY, "run", "--config",
       config_, "--rig", "modbus-tcp://127.0.0.1:" + std::to_string(port),
       "--log-dir", log_dir, "--quiet"},
      Path("run.out"));
  EXPECT_EQ(run.Wait(), 3) << run.Output();
  EXPECT_NE(run.Output().find("tripped: log_write_error (" + log_dir +
                              "/run.csv.partial: File too large; its "),
            std::string::npos)
      << run.Output();
  EXPECT_FALSE(std::filesystem::exists(log_dir + "/run.csv"));
  std::ifstream in(log_dir + "/run.csv.partial");
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  ASSERT_FALSE(text.empty());
  EXPECT_LE(text.size(), 1000000u);
  EXPECT_EQ(text.back(), '\n');
  const long rows = std::count(text.begin(), text.end(), '\n') - 1;
  const nlohmann::json sidecar = ReadJson(log_dir + "/run.json");
  EXPECT_EQ(sidecar["samples"].get<long>(), rows);
  EXPECT_EQ(sidecar["hil"]["safety"]["cause"], "log_write_error");
  EXPECT_FALSE(sidecar["hil"]["completed"]);
  // Renamed, the kept rows are a log like any other.
  std::filesystem::rename(log_dir + "/run.csv.partial", log_dir + "/run.csv");
  const Csv csv = ReadCsv(log_dir + "/run.csv");
  EXPECT_EQ(static_cast<long>(csv.rows.size()), rows);
}

// A disk that fills up: a 1 MiB tmpfs, mounted in a mount namespace of its
// own (nothing stays mounted; needs root, as the realtime tier does). The
// room reserved at the start still takes the sidecar and timing.json.
TEST_F(HilCliTest, AFullDiskTripsTheRunAndStillGetsItsRecord) {
  const int port = StartEmulator();
  const std::string disk = Path("disk"), kept = Path("kept");
  std::filesystem::create_directories(disk);
  const char script[] =
      "mount -t tmpfs -o size=1m kcrig-full \"$1\" || exit 99; "
      "\"$2\" run --config \"$3\" --rig \"$4\" --log-dir \"$1/run\" --quiet; "
      "code=$?; cp -a \"$1/run\" \"$5\"; exit $code";
  ChildProcess run({"/usr/bin/unshare", "-m", "--propagation", "private",
                    "/bin/sh", "-c", script, "sh", disk, KCRIG_BINARY, config_,
                    "modbus-tcp://127.0.0.1:" + std::to_string(port), kept},
                   Path("run.out"));
  ASSERT_EQ(run.Wait(), 3) << run.Output();
  EXPECT_NE(run.Output().find("tripped: log_write_error (" + disk +
                              "/run/run.csv.partial: No space left on device; "
                              "its "),
            std::string::npos)
      << run.Output();
  EXPECT_FALSE(std::filesystem::exists(kept + "/run.csv"));
  EXPECT_FALSE(std::filesystem::exists(kept + "/run.csv.reserve"));
  std::ifstream in(kept + "/run.csv.partial");
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  ASSERT_FALSE(text.empty());
  EXPECT_EQ(text.back(), '\n');
  const long rows = std::count(text.begin(), text.end(), '\n') - 1;
  const nlohmann::json sidecar = ReadJson(kept + "/run.json");
  EXPECT_EQ(sidecar["samples"].get<long>(), rows);
  EXPECT_EQ(sidecar["hil"]["safety"]["cause"], "log_write_error");
  EXPECT_FALSE(ReadJson(kept + "/timing.json")["budget"]["within"].get<bool>());
}

// The controller's memory does not grow with the run: rows stream to disk
// and only counters stay (once every row stayed: 380 bytes a row, 8 MB more
// for the longer run here).
TEST_F(HilCliTest, MemoryDoesNotGrowWithTheRun) {
  const int port = StartEmulator();
  auto peak = [&](const std::string& name,
                  const std::vector<std::string>& extra) {
    auto run = StartRun(port, Path(name), extra);
    EXPECT_EQ(run->Wait(120), 0) << run->Output();
    return ReadJson(Path(name) + "/run.json")["hil"]["peak_memory_mib"]
        .get<double>();
  };
  const double short_run = peak("short", {"--duration", "1"});
  const double long_run = peak("long", {"--duration", "1", "--hold", "20"});
  std::printf("peak memory: %.1f MiB for 3.7 s, %.1f MiB for 23.7 s\n",
              short_run, long_run);
  EXPECT_GT(short_run, 1.0);
  EXPECT_LT(long_run - short_run, 2.0)
      << short_run << " MiB for 3.7 s, " << long_run << " MiB for 23.7 s";
}

TEST_F(HilCliTest, SigtermRampsDownAndKeepsTheLog) {
  const int port = StartEmulator();
  const std::string log_dir = Path("run");
  auto run = StartRun(port, log_dir);
  std::this_thread::sleep_for(std::chrono::milliseconds(3000));
  run->Signal(SIGTERM);
  const int code = run->Wait();
  ExpectSafeStop(code, log_dir, "signal", run->Output());
  EXPECT_NE(run->Output().find("SIGTERM"), std::string::npos);
}

// An impatient second Ctrl-C during the ramp-down (0.5 s) does not cut it
// short: the ramp-down completes and every file is finished.
TEST_F(HilCliTest, ASecondCtrlCDoesNotCutTheRampDownShort) {
  const int port = StartEmulator();
  const std::string log_dir = Path("run");
  auto run = StartRun(port, log_dir);
  std::this_thread::sleep_for(std::chrono::milliseconds(3000));
  run->Signal(SIGINT);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  run->Signal(SIGINT);
  const int code = run->Wait();
  ExpectSafeStop(code, log_dir, "signal", run->Output());
  EXPECT_NE(run->Output().find("once more to kill at once"), std::string::npos)
      << run->Output();
  EXPECT_FALSE(std::filesystem::exists(log_dir + "/run.csv.partial"));
  EXPECT_FALSE(std::filesystem::exists(log_dir + "/run.csv.reserve"));
}

TEST_F(HilCliTest, BadRigsAndOptionsAreOneLineErrors) {
  const struct {
    std::string arguments;
    std::string message;
  } cases[] = {
      {"run --rig modbus-tcp://127.0.0.1:1 --log-dir " + Path("a"),
       "cannot connect"},
      // No such interface: the kernel lacks CAN or the interface.
      {"run --rig can:nocan7 --log-dir " + Path("a"), "can:nocan7: "},
      {"run --rig can: --log-dir " + Path("a"), "expected can:IFACE"},
      {"run --rig serial:/dev/x --log-dir " + Path("a"),
       "expected modbus-tcp://HOST:PORT"},
      {"run --rig modbus-tcp://127.0.0.1:99999 --log-dir " + Path("a"),
       "port '99999' is not in 1..65535"},
      {"run --rig modbus-tcp://127.0.0.1:1502 --fmax 9000 --log-dir " +
           Path("a"),
       "safety.force_max"},
      {"emulate --modbus-tcp 127.0.0.1", "expected HOST:PORT"},
      {"emulate --modbus-tcp 127.0.0.1:0 --effect wobble", "unknown effect"},
      {"emulate --can nocan7", "can:nocan7: "},
      {"emulate --can vcan0 --modbus-tcp 127.0.0.1:0", "give one of"},
      {"run --rig modbus-tcp://127.0.0.1:1502 --inject lost:at=5 --log-dir " +
           Path("a"),
       "--inject: only the embedded rig (--rig sim)"},
      {"run --rig sim --inject wobble:at=5 --log-dir " + Path("a"),
       "--inject wobble:at=5: unknown fault"},
      {"run --rig sim --inject nan:at=5 --log-dir " + Path("a"),
       "needs at=CYCLE and channel="},
      {"campaign --rig modbus-tcp://127.0.0.1:1502 --seed 3 --out " + Path("c"),
       "--seed: only the embedded rig (--rig sim)"},
  };
  for (const auto& c : cases) {
    const CliResult r = RunKcrig(c.arguments);
    EXPECT_EQ(r.exit_code, 1) << c.arguments << "\n" << r.output;
    EXPECT_NE(r.output.find(c.message), std::string::npos) << r.output;
    EXPECT_EQ(CountLines(r.output), 1) << r.output;
    EXPECT_FALSE(std::filesystem::exists(Path("a/run.csv")));
  }
  const std::string config = EditedConfig("rig.yaml", "watchdog_cycles: 20",
                                          "watchdog_cycles: twenty");
  const CliResult r =
      RunKcrig("run --config " + config +
               " --rig modbus-tcp://127.0.0.1:1502 --log-dir " + Path("a"));
  EXPECT_NE(r.output.find("rig.yaml:"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("safety.watchdog_cycles"), std::string::npos)
      << r.output;
}

TEST_F(HilCliTest, TimingCheckReportsPhasesBaselineAndBudget) {
  const int port = StartEmulator();
  CliResult r =
      RunKcrig("timing-check --config " + config_ +
               " --duration 1 --baseline 0.5 --rig modbus-tcp://127.0.0.1:" +
               std::to_string(port) + " --out " + Path("t.json"));
  EXPECT_TRUE(r.exit_code == 0 || r.exit_code == 4) << r.output;
  const nlohmann::json timing = ReadJson(Path("t.json"));
  for (const char* phase : {"wakeup", "read", "compute", "write", "cycle"}) {
    EXPECT_GT(timing["phases"][phase]["count"].get<long>(), 900) << phase;
    EXPECT_GT(timing["phases"][phase]["max_us"].get<double>(), 0) << phase;
  }
  EXPECT_GT(timing["baseline_wakeup"]["count"].get<long>(), 450);
  EXPECT_EQ(r.exit_code == 0, timing["budget"]["within"].get<bool>());
  // So is the link: a pass had no failed read or write, no stale sample.
  const nlohmann::json& link = timing["link"];
  ASSERT_TRUE(link.is_object()) << timing.dump();
  if (r.exit_code == 0) {
    EXPECT_EQ(link["read_errors"], 0) << link.dump();
    EXPECT_EQ(link["write_errors"], 0) << link.dump();
    EXPECT_EQ(link["stale_samples"], 0) << link.dump();
    EXPECT_TRUE(link["release_error"].is_null()) << link.dump();
  }
  // Overruns are part of the budget.
  EXPECT_EQ(timing["budget"]["overrun_max_fraction"], 0.001);
  const bool overran =
      timing["overruns"].get<double>() > 0.001 * timing["cycles"].get<double>();
  EXPECT_EQ(overran, timing["budget"]["violations"].dump().find("overruns") !=
                         std::string::npos)
      << timing.dump();
  EXPECT_NE(r.output.find("baseline wake-up"), std::string::npos);
  // Without the privileges (a user namespace has no CAP_SYS_NICE in the
  // host), the loop goes on and says so, on the terminal and in the file.
  r = RunKcrig("timing-check --config " + std::string(KCRIG_TEST_CONFIG_DIR) +
                   " --duration 0.3 --baseline 0 --out " + Path("u.json"),
               "unshare --user ");
  EXPECT_TRUE(r.exit_code == 0 || r.exit_code == 4) << r.output;
  EXPECT_NE(r.output.find("warning: SCHED_FIFO priority 80 refused"),
            std::string::npos)
      << r.output;
  const nlohmann::json unprivileged = ReadJson(Path("u.json"));
  EXPECT_FALSE(unprivileged["realtime"]["sched_fifo"].get<bool>());
  EXPECT_GE(unprivileged["realtime"]["warnings"].size(), 1u);
  // An impossible budget fails with the reason.
  const std::string config =
      EditedConfig("rig.yaml", "wakeup_p99: 0.0005", "wakeup_p99: 1.0e-6");
  r = RunKcrig("timing-check --config " + config +
               " --duration 0.3 --baseline 0");
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_NE(r.output.find("over budget: wake-up latency p99"),
            std::string::npos)
      << r.output;
}

// A rig that dies during the timing check, or a Ctrl-C, ends the loop
// early: the trip is on screen and in timing.json, and the exit is never 0.
TEST_F(HilCliTest, TimingCheckNeverPassesWhenTheRigDiesOrTheLoopIsStopped) {
  const int port = StartEmulator();
  ChildProcess check({KCRIG_BINARY, "timing-check", "--config", config_,
                      "--duration", "4", "--baseline", "0", "--rig",
                      "modbus-tcp://127.0.0.1:" + std::to_string(port), "--out",
                      Path("t.json")},
                     Path("check.out"));
  std::this_thread::sleep_for(std::chrono::milliseconds(2000));
  emulator_->Signal(SIGKILL);
  EXPECT_EQ(check.Wait(), 3) << check.Output();
  EXPECT_NE(check.Output().find("tripped: watchdog"), std::string::npos)
      << check.Output();
  EXPECT_NE(check.Output().find("NOT CHECKED"), std::string::npos)
      << check.Output();
  const nlohmann::json timing = ReadJson(Path("t.json"));
  EXPECT_NE(timing["trip"].get<std::string>().find("watchdog"),
            std::string::npos)
      << timing["trip"];
  EXPECT_FALSE(timing["budget"]["within"].get<bool>());
  // A rig that dies within the watchdog's count of the end (here its
  // longest, 1 s): the loop runs to its end untripped, but the link's
  // failures over the whole run fail the check.
  const std::string patient =
      EditedConfig("rig.yaml", "watchdog_cycles: 20", "watchdog_cycles: 1000");
  const int second_port = StartEmulator({}, patient);
  ChildProcess dying({KCRIG_BINARY, "timing-check", "--config", patient,
                      "--duration", "4", "--baseline", "0", "--rig",
                      "modbus-tcp://127.0.0.1:" + std::to_string(second_port),
                      "--out", Path("dying.json")},
                     Path("dying.out"));
  std::this_thread::sleep_for(std::chrono::milliseconds(3600));
  emulator_->Signal(SIGKILL);
  // 4 (the link failed); 3 only if a slow start let the errors reach the
  // watchdog's count.
  const int dying_code = dying.Wait();
  EXPECT_TRUE(dying_code == 4 || dying_code == 3) << dying.Output();
  if (dying_code == 4) {
    EXPECT_NE(dying.Output().find("the link failed"), std::string::npos)
        << dying.Output();
  }
  const nlohmann::json link = ReadJson(Path("dying.json"))["link"];
  EXPECT_GT(link["read_errors"].get<long>(), 0) << link.dump();
  EXPECT_TRUE(link["release_error"].is_string()) << link.dump();
  ChildProcess stopped({KCRIG_BINARY, "timing-check", "--config", config_,
                        "--duration", "4", "--baseline", "0"},
                       Path("stopped.out"));
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  stopped.Signal(SIGINT);
  EXPECT_EQ(stopped.Wait(), 130) << stopped.Output();
}

}  // namespace
}  // namespace kcrig
