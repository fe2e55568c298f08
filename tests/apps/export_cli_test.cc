// `kcrig export` and MAT-file logs against SciPy (scipy.io.loadmat and
// savemat, tests/peers/mat_log_scipy.py): what kcrig writes SciPy reads
// back bit for bit, what SciPy writes kcrig estimates from exactly as from
// the CSV, a rig log's loop columns survive CSV -> MAT -> CSV byte for
// byte, and a corrupt MAT-file is one line.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "records/run_log.h"
#include "tests/support/cli_runner.h"
#include "tests/support/temp_dir_test.h"

namespace kcrig {
namespace {

namespace fs = std::filesystem;

// A level-5 MAT-file's header (version 0x0100, little-endian) and data
// elements, byte by byte: the hostile files of the structural check.
std::string MatHeader(std::uint8_t version_low = 0x00,
                      std::uint8_t version_high = 0x01) {
  std::string header(128, ' ');
  header.replace(0, 10, "MATLAB 5.0");
  header[124] = static_cast<char>(version_low);
  header[125] = static_cast<char>(version_high);
  header[126] = 'I';
  header[127] = 'M';
  return header;
}
std::string Word(std::uint32_t v) {
  std::string w(4, '\0');
  for (int k = 0; k < 4; ++k) w[k] = static_cast<char>((v >> (8 * k)) & 0xff);
  return w;
}
std::string Element(std::uint32_t type, const std::string& data) {
  std::string e =
      Word(type) + Word(static_cast<std::uint32_t>(data.size())) + data;
  e.resize((e.size() + 7) / 8 * 8, '\0');
  return e;
}
// An array's flags, dimensions and one-letter name.
std::string ArrayStart(std::uint32_t array_class, std::uint32_t rows,
                       std::uint32_t cols) {
  return Element(6, Word(array_class) + Word(0)) +
         Element(5, Word(rows) + Word(cols)) + Element(1, "v");
}

std::string ReadFile(const std::string& path) {
  std::stringstream text;
  text << std::ifstream(path, std::ios::binary).rdbuf();
  return text.str();
}

class ExportCliTest : public TempDirTest {
 protected:
  CliResult Peer(const std::string& arguments) {
    return RunCommand("/usr/bin/python3 " KCRIG_TEST_PEERS_DIR
                      "/mat_log_scipy.py " +
                      arguments);
  }
  void Simulate(const std::string& name) {
    const CliResult r = RunKcrig(
        "simulate --duration 1 --hold 0.2 --return 1 --noise "
        "--seed 3 --set c_O1=3.7e6 --out " +
        Path(name));
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  // A rig log with every loop column (fresh, phase, safety, counters, the
  // live model), as `kcrig run` writes one.
  void WriteRigLog(const std::string& name) {
    RunLog log;
    log.has_commanded_force = true;
    log.has_loop_columns = true;
    log.metadata.rate = 1000;
    log.metadata.excitation.duration = 0.002;
    log.metadata.sigma_position = 2e-5;
    log.metadata.sigma_angle = 1.7e-4;
    log.metadata.transport = "modbus-tcp://127.0.0.1:1502";
    const RunPhase phases[4] = {RunPhase::kTare, RunPhase::kRamp,
                                RunPhase::kRamp, RunPhase::kRampDown};
    for (int j = 0; j < 4; ++j) {
      LogSample s;
      s.t = 1e-3 * j;
      s.force << 100.0 * j + 0.1, -3.5, 1.0 / 3.0;
      s.commanded << 100.0 * j, 0, 0;
      s.y << 1e-5 * j, 2e-6, -3e-7, 1e-4, 2e-4, 1.0 / 7.0;
      s.fresh = j != 2;
      s.phase = RunPhaseName(phases[j]);
      s.safety = j == 3 ? 1 : 0;
      s.rig_sample = 4000000000u + j;
      s.rig_status = 0x8001;
      s.predicted << 1e-6 * j, 0, 0, 0, 0, 1e-9;
      log.samples.push_back(s);
    }
    ASSERT_TRUE(WriteRunLog(Path(name), log).ok());
  }
};

TEST_F(ExportCliTest, SciPyReadsWhatKcrigWritesBitForBit) {
  Simulate("run.csv");
  WriteRigLog("rig.csv");
  for (const char* log : {"run", "rig"}) {
    const std::string csv = Path(std::string(log) + ".csv");
    const std::string mat = Path(std::string(log) + ".mat");
    const CliResult r = RunKcrig("export --log " + csv + " --out " + mat);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const CliResult peer = Peer("check " + csv + " " + mat);
    EXPECT_EQ(peer.exit_code, 0) << peer.output;
    std::printf("%s: %s", log, peer.output.c_str());
    // And back: the same CSV, byte for byte.
    const std::string back = Path(std::string(log) + "_back.csv");
    ASSERT_EQ(RunKcrig("export --log " + mat + " --out " + back).exit_code, 0);
    EXPECT_EQ(ReadFile(back), ReadFile(csv)) << log;
    // SciPy's MAT-file of the same log (phases as a cell array, as
    // MATLAB's cellstr) reads back to the same CSV too.
    const std::string peer_mat = Path(std::string(log) + "_peer.mat");
    ASSERT_EQ(Peer("write " + csv + " " + peer_mat).exit_code, 0);
    const std::string peer_back = Path(std::string(log) + "_peer.csv");
    ASSERT_EQ(
        RunKcrig("export --log " + peer_mat + " --out " + peer_back).exit_code,
        0);
    EXPECT_EQ(ReadFile(peer_back), ReadFile(csv)) << log;
  }
}

TEST_F(ExportCliTest, KcrigEstimatesFromSciPysMatFileAsFromTheCsv) {
  Simulate("run.csv");
  const CliResult peer =
      Peer("write " + Path("run.csv") + " " + Path("peer.mat"));
  ASSERT_EQ(peer.exit_code, 0) << peer.output;
  for (const char* log : {"run.csv", "peer.mat"}) {
    const CliResult r = RunKcrig("estimate --log " + Path(log) + " --out " +
                                 Path(std::string(log) + ".est.json"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  const nlohmann::json csv =
      nlohmann::json::parse(std::ifstream(Path("run.csv.est.json")));
  const nlohmann::json mat =
      nlohmann::json::parse(std::ifstream(Path("peer.mat.est.json")));
  ASSERT_EQ(csv["parameters"].size(), 5u);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(csv["parameters"][i]["value"], mat["parameters"][i]["value"]);
    EXPECT_EQ(csv["parameters"][i]["ci95"], mat["parameters"][i]["ci95"]);
  }
}

TEST_F(ExportCliTest, BadMatFilesAreOneLineAndWriteNothing) {
  Simulate("run.csv");
  auto expect_refused = [&](const std::string& mat,
                            const std::string& expected) {
    const CliResult r =
        RunKcrig("export --log " + mat + " --out " + Path("out.csv"));
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_EQ(CountLines(r.output), 1) << r.output;
    EXPECT_NE(r.output.find(expected), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(Path("out.csv")));
  };
  ASSERT_EQ(
      Peer("write " + Path("run.csv") + " " + Path("nan.mat") + " --nan camber")
          .exit_code,
      0);
  expect_refused(Path("nan.mat"),
                 "nan.mat: variable 'camber': element 1101 is not a finite "
                 "number");
  // Not a MAT-file at all, and one cut short.
  std::ofstream(Path("text.mat")) << "t,x\n0,1\n";
  expect_refused(Path("text.mat"), "text.mat: not a readable MAT-file");
  ASSERT_EQ(RunKcrig("export --log " + Path("run.csv") + " --out " +
                     Path("whole.mat"))
                .exit_code,
            0);
  const std::string whole = ReadFile(Path("whole.mat"));
  std::ofstream(Path("cut.mat"), std::ios::binary)
      << whole.substr(0, whole.size() / 2);
  expect_refused(Path("cut.mat"), "cut.mat: not a readable MAT-file");
  // Hostile structures the check refuses before libmatio allocates: a
  // level-4 header (libmatio would parse it as such), an array whose size
  // is not whole 8-byte words, an array claiming a billion doubles, and a
  // hundred thousand and one empty cells.
  std::ofstream(Path("v4.mat"), std::ios::binary)
      << MatHeader(0x00, 0x00) +
             Element(14, ArrayStart(6, 1, 1) + Element(9, std::string(8, 'x')));
  expect_refused(Path("v4.mat"), "not a little-endian level-5 MAT-file");
  std::string odd = ArrayStart(6, 1, 1) + Element(9, std::string(8, 'x'));
  odd += "oddb";
  std::ofstream(Path("odd.mat"), std::ios::binary)
      << MatHeader() + Word(14) + Word(static_cast<std::uint32_t>(odd.size())) +
             odd + "pad!";
  expect_refused(Path("odd.mat"), "not a multiple of 8 bytes");
  std::ofstream(Path("huge.mat"), std::ios::binary)
      << MatHeader() + Element(14, ArrayStart(6, 1000000000, 1) +
                                       Element(9, std::string(8, 'x')));
  expect_refused(Path("huge.mat"), "does not match its dimensions");
  std::string cells = ArrayStart(1, 100001, 1);
  for (int k = 0; k < 100001; ++k) cells += Element(14, "");
  std::ofstream(Path("cells.mat"), std::ios::binary)
      << MatHeader() + Element(14, cells);
  expect_refused(Path("cells.mat"), "more than 100000 arrays");
  // The output's format goes by its extension.
  const CliResult r = RunKcrig("export --log " + Path("run.csv") + " --out " +
                               Path("run.xlsx"));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find(".mat (MATLAB MAT-file) or .csv"), std::string::npos);
}

}  // namespace
}  // namespace kcrig
