// The SocketCAN path with real processes on vcan0: `kcrig emulate --can`,
// `kcrig run --rig can:vcan0`, `kcrig campaign --rig can:vcan0`, the bus
// log against can-utils (candump, canplayer, cansend) and python-can with
// canmatrix, and faults (a silenced emulator, a bus-off error frame).
//
// Needs vcan0: ctest runs this binary through scripts/vcan_vm.sh, which
// boots Debian's kernel under qemu (TCG) where the host kernel has no CAN.
// Without vcan0 every test fails; none is skipped. The guest runs on guest
// time (one vCPU under qemu's -icount, see scripts/vcan_vm.sh), so a busy
// host slows a test down without making its loop late: the tests run with
// rig.yaml's and plant.yaml's own watchdog, force tracking and command
// timeout. No latency is asserted (guest time is no real machine's).
#include <signal.h>
#include <sys/stat.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "gtest/gtest.h"
#include "io_drivers/kc_rig_protocol.h"
#include "nlohmann/json.hpp"
#include "records/can_log_decoder.h"
#include "records/internal/candump_log.h"
#include "tests/support/child_process.h"
#include "tests/support/cli_runner.h"
#include "tests/support/edited_config.h"
#include "tests/support/hil_checks.h"
#include "tests/support/temp_dir_test.h"

namespace kcrig {
namespace {

const char kPython[] = "/usr/bin/python3";
const std::string kPeer =
    std::string(KCRIG_TEST_SOURCE_DIR) + "/io_drivers/python_can_peer.py";
// Bound on a wait for a state (a process ready, a run over) [s of guest
// time]. Guest time races ahead while the guest waits for the host's files
// (scripts/vcan_vm.sh), so a start-up can take minutes of it; the VM's
// wall-clock timeout is the real bound.
constexpr double kGuestWait = 3600;

// ID#DATA of the frames sent by the rig (`rig` true: their time stamps are
// the kernel's, the same in every listener's log) or by the controller
// (kcrig logs those at send time, candump at the kernel's receive time),
// within [from_us, to_us], sorted.
std::vector<std::string> FrameTexts(const std::vector<CandumpRecord>& records,
                                    bool rig, std::int64_t from_us,
                                    std::int64_t to_us) {
  std::vector<std::string> texts;
  for (const CandumpRecord& r : records) {
    if (r.frame.time_us < from_us || r.frame.time_us > to_us) continue;
    if ((r.frame.frame.id >= 0x200) != rig) continue;
    char line[kCandumpLineMax];
    const size_t n = FormatCandumpLine(r.frame, "x", line);
    const std::string text(line, n);
    texts.push_back(text.substr(text.find(' ', text.find(')') + 2) + 1));
  }
  std::sort(texts.begin(), texts.end());
  return texts;
}

// Whether every frame of `inner` (with multiplicity) is in `outer`.
bool Contains(const std::vector<std::string>& outer,
              const std::vector<std::string>& inner) {
  return std::includes(outer.begin(), outer.end(), inner.begin(), inner.end());
}

class VcanTest : public TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    struct stat info;
    ASSERT_EQ(stat("/sys/class/net/vcan0", &info), 0)
        << "no vcan0: run this binary through scripts/vcan_vm.sh run";
    config_ = KCRIG_TEST_CONFIG_DIR;
  }

  void StartEmulator(const std::vector<std::string>& extra = {}) {
    std::vector<std::string> argv = {KCRIG_BINARY, "emulate", "--config",
                                     config_,      "--can",   "vcan0"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    emulator_ = std::make_unique<ChildProcess>(argv, Path("emulate.out"));
    ASSERT_FALSE(
        emulator_->WaitForOutput("kcrig emulate: on can:vcan0", kGuestWait)
            .empty())
        << emulator_->Output();
  }

  std::unique_ptr<ChildProcess> StartRun(
      const std::string& log_dir, const std::vector<std::string>& extra = {}) {
    std::vector<std::string> argv = {KCRIG_BINARY, "run",   "--config",
                                     config_,      "--rig", "can:vcan0",
                                     "--log-dir",  log_dir, "--quiet"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    return std::make_unique<ChildProcess>(argv, Path("run.out"));
  }

  // Waits until the run's loop is under way (its first rows are on disk).
  void WaitForLoop(const std::string& log_dir) {
    const auto end = std::chrono::steady_clock::now() +
                     std::chrono::duration<double>(kGuestWait);
    while (std::chrono::steady_clock::now() < end) {
      std::error_code error;
      if (std::filesystem::file_size(log_dir + "/run.csv.partial", error) >
              20000 &&
          !error) {
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ADD_FAILURE() << "the run's loop did not start";
  }

  nlohmann::json Estimate(const std::string& log, const std::string& out) {
    const CliResult r = RunKcrig("estimate --config " + config_ + " --log " +
                                 log + " --out " + out);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    return ReadJson(out);
  }

  RunLog Decode(const std::string& can_log) {
    CanLogDecoderOptions options;
    options.dbc_file = config_ + "/kc_rig.dbc";
    RunLog log;
    const Status status = DecodeCanLog(can_log, options, &log);
    EXPECT_TRUE(status.ok()) << status.message();
    return log;
  }

  std::string config_;
  std::unique_ptr<ChildProcess> emulator_;
};

// Agreement in standard errors: the estimator models the applied force from
// the command, which can.log carries at the DBC's 0.5 N resolution and
// run.csv at full precision (that quantum moves the estimates by about 5e-4
// of a standard error, measured). A replay of the same frames estimates the
// same to rounding: 1e-6 of a standard error is that, in the same unit.
void ExpectSameEstimate(const nlohmann::json& a, const nlohmann::json& b,
                        double tolerance_in_standard_errors) {
  ASSERT_EQ(a["parameters"].size(), b["parameters"].size());
  for (size_t k = 0; k < a["parameters"].size(); ++k) {
    const double va = a["parameters"][k]["value"];
    const double vb = b["parameters"][k]["value"];
    const double sa = a["parameters"][k]["standard_error"];
    const double sb = b["parameters"][k]["standard_error"];
    EXPECT_NEAR(va, vb, tolerance_in_standard_errors * sa)
        << a["parameters"][k]["name"];
    EXPECT_NEAR(sa, sb, tolerance_in_standard_errors * sa)
        << a["parameters"][k]["name"];
  }
}

TEST_F(VcanTest, FullRampOverCanLogsEveryCycleAndCanLogGivesTheSameEstimate) {
  StartEmulator();
  const std::string log_dir = Path("run");
  // An 8 MiB receive buffer: under TCG candump can be descheduled long
  // enough to overflow the default one, and then misses frames.
  ChildProcess candump({"/usr/bin/candump", "-r", "8388608", "-L", "vcan0"},
                       Path("candump.log"));
  auto run = StartRun(log_dir);
  ASSERT_EQ(run->Wait(kGuestWait), 0) << run->Output();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  candump.Signal(SIGINT);
  candump.Wait();
  EXPECT_NE(run->Output().find("can.log"), std::string::npos) << run->Output();

  // Every cycle is a row, and every row without a fresh sample is counted.
  const nlohmann::json hil = ReadJson(log_dir + "/run.json")["hil"];
  const Csv csv = ReadCsv(log_dir + "/run.csv");
  ASSERT_EQ(csv.rows.size(), 6700u);
  EXPECT_EQ(hil["cycles"].get<long>() + hil["skipped_cycles"].get<long>(),
            6700);
  long without = 0;
  for (const auto& row : csv.rows) without += row[csv.Column("fresh")] == "0";
  EXPECT_EQ(without, hil["read_errors"].get<long>() +
                         hil["stale_samples"].get<long>() +
                         hil["skipped_cycles"].get<long>());
  const nlohmann::json& transport = hil["transport"];
  EXPECT_EQ(transport["malformed_frames"], 0);
  EXPECT_EQ(transport["error_frames"], 0);
  EXPECT_EQ(transport["bus_log_dropped"], 0);
  EXPECT_FALSE(transport.contains("fault"));
  std::printf(
      "CAN run in the guest: %ld of 6700 rows without a fresh sample, %d "
      "frames in can.log\n",
      without, transport["bus_log_frames"].get<int>());
  // The guest holds its period on guest time, however busy the host: a row
  // in a hundred at most goes without a fresh sample (none, measured), and
  // overruns stay within rig.yaml's budget (0.1 % of cycles).
  EXPECT_LE(without, 67);
  EXPECT_LE(hil["overruns"].get<long>(), 6);

  // can.log decodes to run.csv's rows, and estimates the same.
  const RunLog decoded = Decode(log_dir + "/can.log");
  RunLog logged;
  ASSERT_TRUE(ReadRunLog(log_dir + "/run.csv", &logged).ok());
  ASSERT_EQ(decoded.samples.size(), logged.samples.size());
  for (size_t j = 0; j < logged.samples.size(); ++j) {
    const LogSample &a = logged.samples[j], &b = decoded.samples[j];
    ASSERT_EQ(a.fresh, b.fresh) << "row " << j;
    ASSERT_NEAR(a.t, b.t, 1e-9) << "row " << j;
    ASSERT_LT((a.force - b.force).cwiseAbs().maxCoeff(), 1e-9) << "row " << j;
    ASSERT_LT((a.y - b.y).cwiseAbs().maxCoeff(), 1e-12) << "row " << j;
    ASSERT_LE((a.commanded - b.commanded).cwiseAbs().maxCoeff(), 0.25 + 1e-9)
        << "row " << j;  // half the DBC's 0.5 N quantum
  }
  ExpectSameEstimate(Estimate(log_dir + "/run.csv", Path("csv_est.json")),
                     Estimate(log_dir + "/can.log", Path("can_est.json")),
                     1e-2);

  // candump -l saw the same frames as kcrig's own log over the run (away
  // from its ends, where one of the two was not listening yet).
  std::vector<CandumpRecord> ours, theirs;
  ASSERT_TRUE(ReadCandumpLog(log_dir + "/can.log", &ours).ok());
  const Status read = ReadCandumpLog(Path("candump.log"), &theirs);
  ASSERT_TRUE(read.ok()) << read.message();
  std::int64_t first = INT64_MAX, last = 0;
  for (const CandumpRecord& r : ours) {
    first = std::min(first, r.frame.time_us);
    last = std::max(last, r.frame.time_us);
  }
  const std::int64_t from = first + 200000, to = last - 200000;
  const auto rig_frames = FrameTexts(ours, true, from, to);
  EXPECT_GT(rig_frames.size(), 20000u);
  EXPECT_TRUE(rig_frames == FrameTexts(theirs, true, from, to))
      << rig_frames.size() << " rig frames in can.log, "
      << FrameTexts(theirs, true, from, to).size() << " in candump's capture";
  // The controller's frames: the same, up to the two clocks' difference at
  // the window's ends.
  const std::int64_t slack = 50000;
  EXPECT_TRUE(Contains(FrameTexts(theirs, false, from - slack, to + slack),
                       FrameTexts(ours, false, from, to)));
  EXPECT_TRUE(Contains(FrameTexts(ours, false, from - slack, to + slack),
                       FrameTexts(theirs, false, from, to)));
  EXPECT_GT(FrameTexts(ours, false, from, to).size(), 5000u);

  // python-can reads the log and canmatrix decodes its samples, with
  // config/kc_rig.dbc alone, to the values run.csv logged.
  const CliResult python =
      RunCommand(std::string(kPython) + " " + kPeer + " decode " + config_ +
                 "/kc_rig.dbc " + log_dir + "/can.log " + Path("py.csv"));
  ASSERT_EQ(python.exit_code, 0) << python.output;
  const Csv peer = ReadCsv(Path("py.csv"));
  size_t next = 0, matched = 0, fresh = 0;
  const char* channels[] = {"x", "y", "z", "toe", "camber", "caster"};
  const char* peer_channels[] = {"X", "Y", "Z", "Toe", "Camber", "Caster"};
  for (size_t j = 0; j < csv.rows.size(); ++j) {
    if (csv.rows[j][csv.Column("fresh")] != "1") continue;
    ++fresh;
    const long counter = std::stol(csv.rows[j][csv.Column("rig_sample")]) % 256;
    while (next < peer.rows.size() && peer.Value(next, "Counter") != counter) {
      ++next;
    }
    if (next == peer.rows.size()) break;
    bool same = std::abs(peer.Value(next, "Fx") - csv.Value(j, "Fx")) < 1e-9;
    for (int c = 0; c < 6; ++c) {
      same &= std::abs(peer.Value(next, peer_channels[c]) -
                       csv.Value(j, channels[c])) < 1e-12;
    }
    matched += same;
    ++next;
  }
  EXPECT_EQ(matched, fresh) << "fresh rows python-can/canmatrix decoded alike";
}

TEST_F(VcanTest, CanplayerReplaysTheLogAndKcrigDecodesTheSameValues) {
  StartEmulator();
  const std::string log_dir = Path("run");
  auto run = StartRun(log_dir, {"--duration", "1"});
  ASSERT_EQ(run->Wait(kGuestWait), 0) << run->Output();
  emulator_.reset();  // the bus is quiet for the replay

  ChildProcess logger({KCRIG_BINARY, "can-log", "--can", "vcan0", "--out",
                       Path("replayed.log")},
                      Path("can_log.out"));
  ASSERT_FALSE(logger.WaitForOutput("logging can:vcan0", kGuestWait).empty())
      << logger.Output();
  const CliResult play =
      RunCommand("/usr/bin/canplayer -I " + log_dir + "/can.log");
  ASSERT_EQ(play.exit_code, 0) << play.output;
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  logger.Signal(SIGINT);
  ASSERT_EQ(logger.Wait(), 0) << logger.Output();

  // The replay carries the same frames in the same order ...
  std::vector<CandumpRecord> original, replayed;
  ASSERT_TRUE(ReadCandumpLog(log_dir + "/can.log", &original).ok());
  ASSERT_TRUE(ReadCandumpLog(Path("replayed.log"), &replayed).ok());
  ASSERT_EQ(replayed.size(), original.size()) << logger.Output();
  for (size_t k = 0; k < original.size(); ++k) {
    const CanFrame &a = original[k].frame.frame, &b = replayed[k].frame.frame;
    ASSERT_TRUE(a.id == b.id && a.dlc == b.dlc &&
                std::equal(a.data, a.data + 8, b.data))
        << "frame " << k;
  }
  // ... so it decodes to the same rows and the same estimate.
  const RunLog a = Decode(log_dir + "/can.log");
  const RunLog b = Decode(Path("replayed.log"));
  ASSERT_EQ(a.samples.size(), b.samples.size());
  for (size_t j = 0; j < a.samples.size(); ++j) {
    ASSERT_EQ(a.samples[j].force, b.samples[j].force) << j;
    ASSERT_EQ(a.samples[j].y, b.samples[j].y) << j;
    ASSERT_EQ(a.samples[j].commanded, b.samples[j].commanded) << j;
    ASSERT_EQ(a.samples[j].fresh, b.samples[j].fresh) << j;
  }
  ExpectSameEstimate(Estimate(log_dir + "/can.log", Path("a.json")),
                     Estimate(Path("replayed.log"), Path("b.json")), 1e-6);
}

TEST_F(VcanTest, MalformedAndForeignFramesAreCountedWithoutDisturbingTheLoop) {
  StartEmulator();
  const std::string log_dir = Path("run");
  auto run = StartRun(log_dir);
  WaitForLoop(log_dir);
  // Wrong length, remote frames and an unknown id in the rig's id page are
  // seen and counted; an extended id and an id outside the rig's pages are
  // kept out by the receive filters. canplayer sends them all at once.
  const std::vector<std::string> counted_malformed = {"201#0102", "204#R",
                                                      "202#00"};
  const std::vector<std::string> counted_unknown = {"2FF#0011223344556677"};
  const std::vector<std::string> filtered = {"123#00",
                                             "00000201#0102030405060708"};
  const int rounds = 3;
  {
    std::ofstream junk(Path("junk.log"));
    int k = 0;
    for (int round = 0; round < rounds; ++round) {
      for (const auto* list :
           {&counted_malformed, &counted_unknown, &filtered}) {
        for (const std::string& frame : *list) {
          junk << "(1700000000." << 100000 + 1000 * k++ << ") vcan0 " << frame
               << "\n";
        }
      }
    }
  }
  const CliResult play =
      RunCommand("/usr/bin/canplayer -I " + Path("junk.log"));
  ASSERT_EQ(play.exit_code, 0) << play.output;
  ASSERT_TRUE(std::filesystem::exists(log_dir + "/run.csv.partial"))
      << "the run ended before the frames were sent";
  ASSERT_EQ(run->Wait(kGuestWait), 0) << run->Output();
  const nlohmann::json transport =
      ReadJson(log_dir + "/run.json")["hil"]["transport"];
  EXPECT_EQ(transport["malformed_frames"],
            rounds * static_cast<int>(counted_malformed.size()));
  EXPECT_EQ(transport["unknown_id_frames"],
            rounds * static_cast<int>(counted_unknown.size()));
  EXPECT_EQ(ReadCsv(log_dir + "/run.csv").rows.size(), 6700u);
  // Nor do they reach the estimate: the plant is still found.
  const nlohmann::json est = Estimate(log_dir + "/run.csv", Path("est.json"));
  EXPECT_LT(est["sigma_hat"].get<double>(), 1.3);
}

TEST_F(VcanTest, PythonCanStandInRigDrivesTheController) {
  const int cycles = 150;
  ChildProcess rig({kPython, kPeer, "rig", config_ + "/kc_rig.dbc", "vcan0",
                    std::to_string(cycles), Path("sent.csv")},
                   Path("rig.out"));
  ASSERT_FALSE(rig.WaitForOutput("stand-in rig on vcan0", kGuestWait).empty())
      << rig.Output();
  const std::string log_dir = Path("run");
  // A stand-in that does not move: a small force keeps the model's
  // prediction within the error detector's limits.
  auto run = StartRun(log_dir, {"--fmax", "20"});
  const int code = run->Wait(kGuestWait);
  ASSERT_EQ(rig.Wait(kGuestWait), 0) << rig.Output();
  // The rig fell silent after its cycles: the watchdog stops the run.
  ExpectSafeStop(code, log_dir, "watchdog", run->Output());
  const Csv sent = ReadCsv(Path("sent.csv"));
  const Csv csv = ReadCsv(log_dir + "/run.csv");
  std::map<long, size_t> by_counter;  // the last sample sent per counter
  for (size_t k = 0; k < sent.rows.size(); ++k) {
    by_counter[std::lround(sent.Value(k, "Counter"))] = k;
  }
  long fresh = 0;
  for (size_t j = 0; j < csv.rows.size(); ++j) {
    if (csv.rows[j][csv.Column("fresh")] != "1") continue;
    ++fresh;
    const long counter = std::stol(csv.rows[j][csv.Column("rig_sample")]) % 256;
    ASSERT_TRUE(by_counter.count(counter)) << "row " << j;
    const size_t k = by_counter[counter];
    EXPECT_NEAR(csv.Value(j, "x"), sent.Value(k, "X"), 1e-12) << "row " << j;
    EXPECT_NEAR(csv.Value(j, "Fx"), sent.Value(k, "Fx"), 1e-9) << "row " << j;
    EXPECT_NEAR(csv.Value(j, "caster"), 6e-6, 1e-12) << "row " << j;
  }
  EXPECT_GE(fresh, 20) << rig.Output();
  std::printf("python-can stand-in rig: %ld fresh samples in the log\n", fresh);
}

// The session the run claimed the rig with: the Session byte of the first
// KC_Session (id 0x102) in its bus log.
int ClaimedSession(const std::string& bus_log) {
  std::vector<CandumpRecord> records;
  EXPECT_TRUE(ReadCandumpLog(bus_log, &records).ok());
  for (const CandumpRecord& r : records) {
    if (r.frame.frame.id == 0x102) return r.frame.frame.data[0] & 0x7F;
  }
  ADD_FAILURE() << "no KC_Session in " << bus_log;
  return 0;
}

// One master on CAN too: a second kcrig is refused before it sends a frame;
// another session's commands and claims are refused by the rig, counted on
// both sides and never move it, during the run and after it (an unclaimed
// rig obeys no enable); a frame that carries the owner's session, which the
// rig cannot tell apart, trips the owner.
TEST_F(VcanTest, TheRigObeysOneMasterOnCanToo) {
  StartEmulator();
  const std::string log_dir = Path("run");
  auto run = StartRun(log_dir);
  WaitForLoop(log_dir);
  const CliResult second =
      RunKcrig("run --config " + config_ + " --rig can:vcan0 --log-dir " +
               Path("second"));
  EXPECT_EQ(second.exit_code, 1) << second.output;
  EXPECT_NE(second.output.find("the rig refuses this controller: another "
                               "master (session "),
            std::string::npos)
      << second.output;
  EXPECT_EQ(CountLines(second.output), 1) << second.output;
  EXPECT_FALSE(std::filesystem::exists(Path("second/run.csv")));
  // Enable with 6 kN in Fz under session 0 (never granted), and a claim for
  // another session than the owner's (a fixed one is the owner's one run in
  // 127: the run draws its session), 20 times each.
  const int rounds = 20;
  const int other =
      ClaimedSession(log_dir + "/can.log.partial") % kMaxCanSession + 1;
  auto rogue = [&](bool claims) {
    const std::string path = Path(claims ? "rogue.log" : "enables.log");
    std::ofstream out(path);
    for (int k = 0; k < rounds; ++k) {
      out << "(1700000000." << 100000 + 2000 * k
          << ") vcan0 100#00000000E02E0001\n";
      if (claims) {
        char claim[32];
        std::snprintf(claim, sizeof(claim), "102#%02X01000000000000", other);
        out << "(1700000000." << 101000 + 2000 * k << ") vcan0 " << claim
            << "\n";
      }
    }
    out.close();
    return RunCommand("/usr/bin/canplayer -I " + path).exit_code;
  };
  ASSERT_EQ(rogue(true), 0);
  ASSERT_TRUE(std::filesystem::exists(log_dir + "/run.csv.partial"))
      << "the run ended before the rogue's frames were sent";
  ASSERT_EQ(run->Wait(kGuestWait), 0) << run->Output();
  const nlohmann::json transport =
      ReadJson(log_dir + "/run.json")["hil"]["transport"];
  EXPECT_EQ(transport["foreign_frames"], 2 * rounds);
  EXPECT_GE(transport["refusing_heartbeats"].get<int>(), 1);
  // Fz is never commanded (phi lies in the x-y plane): 6 kN would show.
  const Csv csv = ReadCsv(log_dir + "/run.csv");
  for (size_t j = 0; j < csv.rows.size(); ++j) {
    ASSERT_LT(std::abs(csv.Value(j, "Fz")), 100.0) << "row " << j;
  }
  // can.log still decodes to the owner's rows alone.
  EXPECT_EQ(Decode(log_dir + "/can.log").samples.size(), csv.rows.size());
  ASSERT_EQ(rogue(false), 0);  // the rig is unclaimed now

  const std::string impersonated = Path("run2");
  run = StartRun(impersonated);
  WaitForLoop(impersonated);
  std::this_thread::sleep_for(std::chrono::seconds(1));  // into the ramp
  const int session = ClaimedSession(impersonated + "/can.log.partial");
  char frame[64];
  std::snprintf(frame, sizeof(frame), "100#00000000E02E00%02X",
                1 | (session << 1));
  ASSERT_EQ(
      RunCommand(std::string("/usr/bin/cansend vcan0 ") + frame).exit_code, 0);
  const int code = run->Wait(kGuestWait);
  ExpectSafeStop(code, impersonated, "foreign_master", run->Output());
  const std::string fault =
      ReadJson(impersonated + "/run.json")["hil"]["transport"]["fault"];
  EXPECT_NE(fault.find("with this controller's session"), std::string::npos)
      << fault;

  emulator_->Signal(SIGINT);
  ASSERT_EQ(emulator_->Wait(kGuestWait), 0) << emulator_->Output();
  const std::string refused =
      emulator_->WaitForOutput("refused frames ([0-9]+)", 1);
  ASSERT_FALSE(refused.empty()) << emulator_->Output();
  // During the run: 20 commands and 20 claims; after it: 20 enables without
  // a claim; and the impersonating frame is obeyed (indistinguishable).
  EXPECT_EQ(std::stol(refused), 3 * rounds) << emulator_->Output();
}

TEST_F(VcanTest, SilencedEmulatorTripsTheWatchdogAndTheForceRampsToZero) {
  StartEmulator();
  const std::string log_dir = Path("run");
  auto run = StartRun(log_dir);
  WaitForLoop(log_dir);
  std::this_thread::sleep_for(std::chrono::seconds(2));
  emulator_->Signal(SIGSTOP);
  const int code = run->Wait(kGuestWait);
  emulator_->Signal(SIGCONT);
  ExpectSafeStop(code, log_dir, "watchdog", run->Output());
}

TEST_F(VcanTest, BusOffErrorFrameEndsInTheSafeStateWithTheCauseLogged) {
  StartEmulator();
  const std::string log_dir = Path("run");
  auto run = StartRun(log_dir);
  WaitForLoop(log_dir);
  std::this_thread::sleep_for(std::chrono::seconds(2));
  // CAN_ERR_FLAG | CAN_ERR_BUSOFF, as a controller reports bus-off.
  const CliResult sent =
      RunCommand("/usr/bin/cansend vcan0 20000040#0000000000000000");
  ASSERT_EQ(sent.exit_code, 0) << sent.output;
  const int code = run->Wait(kGuestWait);
  ExpectSafeStop(code, log_dir, "transport_fault", run->Output());
  EXPECT_NE(run->Output().find("CAN bus-off"), std::string::npos)
      << run->Output();
  const nlohmann::json hil = ReadJson(log_dir + "/run.json")["hil"];
  EXPECT_EQ(hil["transport"]["fault"], "CAN bus-off");
  EXPECT_EQ(hil["transport"]["error_frames"], 1);
}

TEST_F(VcanTest, FullTransmitQueueIsATxTimeoutWithinTheBoundedTime) {
  // The emulator answers each command with a sample, so a rig that stops
  // getting commands falls silent too, and the watchdog (20 cycles) would
  // end the run before the transmit timeout (20 ms after the queue fills):
  // the transmit path is under test here.
  config_ = EditConfig(Path("config"), "rig.yaml", "watchdog_cycles: 20",
                       "watchdog_cycles: 100");
  StartEmulator();
  const std::string log_dir = Path("run");
  auto run = StartRun(log_dir);
  WaitForLoop(log_dir);
  std::this_thread::sleep_for(std::chrono::seconds(1));
  // A token bucket of 4 frames and about 8 frames/s for the controller's
  // frames (ids 0x100-0x1FF) alone: within a few cycles their queue fills
  // and sends fail with ENOBUFS, as on a bus that stopped taking our frames,
  // well before the rig's command watchdog (50 ms) releases the claim. The
  // rig's own frames share vcan0's queue here (not on a real bus) and are
  // let through.
  for (const char* tc :
       {"qdisc add dev vcan0 root handle 1: prio",
        "qdisc add dev vcan0 parent 1:1 handle 10: tbf rate 1kbit burst 64 "
        "limit 64",
        "filter add dev vcan0 parent 1: prio 1 basic match "
        "'canid(sff 0x100:0x700)' flowid 1:1"}) {
    const CliResult slow = RunCommand(std::string("/usr/sbin/tc ") + tc);
    ASSERT_EQ(slow.exit_code, 0) << tc << ": " << slow.output;
  }
  const int code = run->Wait(kGuestWait);
  RunCommand("/usr/sbin/tc qdisc del dev vcan0 root");
  ExpectSafeStop(code, log_dir, "transport_fault", run->Output());
  const nlohmann::json transport =
      ReadJson(log_dir + "/run.json")["hil"]["transport"];
  // The cause first; the rig's command watchdog may release the claim
  // during the ramp-down, whose commands cannot get out either.
  const std::string fault = transport["fault"];
  EXPECT_EQ(fault.rfind("CAN tx timeout (transmit queue full, ENOBUFS)", 0), 0u)
      << fault;
  EXPECT_GT(transport["transmit_queue_full"].get<int>(), 0);
}

TEST_F(VcanTest, InterfaceDownEndsInTheSafeState) {
  StartEmulator();
  const std::string log_dir = Path("run");
  auto run = StartRun(log_dir);
  WaitForLoop(log_dir);
  std::this_thread::sleep_for(std::chrono::seconds(1));
  ASSERT_EQ(RunCommand("/usr/sbin/ip link set vcan0 down").exit_code, 0);
  const int code = run->Wait(kGuestWait);
  ASSERT_EQ(RunCommand("/usr/sbin/ip link set vcan0 up").exit_code, 0);
  ExpectSafeStop(code, log_dir, "transport_fault", run->Output());
  EXPECT_NE(run->Output().find("CAN interface down"), std::string::npos)
      << run->Output();
}

TEST_F(VcanTest, CampaignRunsItsExperimentsOverCan) {
  StartEmulator();
  // The transport is under test, not the model: a diagnosis in the guest
  // would take minutes.
  const CliResult r = RunKcrig("campaign --config " + config_ +
                               " --rig can:vcan0 --iterations 1 --budget 12 "
                               "--quiet --no-report --no-diagnose --out " +
                               Path("campaign"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json campaign = ReadJson(Path("campaign") + "/campaign.json");
  ASSERT_EQ(campaign["iterations"].size(), 2u);
  EXPECT_TRUE(campaign["iterations"][1]["adequacy"].contains("verdict"));
  EXPECT_TRUE(campaign["iterations"][1]["diagnosis"].is_null());
  for (const char* file :
       {"iteration_0/run.csv", "iteration_0/can.log", "iteration_1/can.log",
        "iteration_1/est.json", "campaign.json"}) {
    EXPECT_TRUE(std::filesystem::exists(Path("campaign") + "/" + file)) << file;
  }
  const nlohmann::json run =
      ReadJson(Path("campaign") + "/iteration_1/run.json");
  EXPECT_EQ(run["transport"], "can:vcan0");
}

}  // namespace
}  // namespace kcrig
