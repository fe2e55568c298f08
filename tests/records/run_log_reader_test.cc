// Acceptance 5 of the estimator issue at the reader: every kind of bad log
// is one line naming the file (and the line where there is one).
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "gtest/gtest.h"
#include "records/run_log.h"
#include "tests/support/temp_dir_test.h"

namespace kcrig {
namespace {

namespace fs = std::filesystem;

class RunLogReaderTest : public TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    RunLog log;
    for (int j = 0; j < 5; ++j) {
      LogSample s;
      s.t = 1e-3 * j;
      s.force << 10.0 * j, -5.0, 0;
      s.y << 1e-6 * j, 2e-6, 3e-6, 1e-5, 2e-5, 3e-5;
      log.samples.push_back(s);
    }
    log.metadata.rate = 1000;
    log.metadata.sigma_position = 2e-5;
    log.metadata.sigma_angle = 1.7e-4;
    log.metadata.excitation.duration = 0.004;
    log.metadata.transport = "simulation";
    ASSERT_TRUE(WriteRunLog(Csv(), log).ok());
    std::ifstream in(Csv());
    std::stringstream text;
    text << in.rdbuf();
    csv_ = text.str();
  }

  std::string Csv() const { return (dir_ / "run.csv").string(); }
  void WriteCsv(const std::string& text) { std::ofstream(Csv()) << text; }
  std::string Error() {
    RunLog log;
    const Status status = ReadRunLog(Csv(), &log);
    EXPECT_FALSE(status.ok());
    EXPECT_EQ(status.message().find('\n'), std::string::npos);
    // Names the CSV or, for sidecar problems, the sidecar.
    EXPECT_EQ(status.message().rfind((dir_ / "run.").string(), 0), 0u)
        << status.message();
    return status.message();
  }
  // Replaces the n-th line (1-based) of the CSV.
  void ReplaceLine(int n, const std::string& line) {
    std::istringstream in(csv_);
    std::string out, current;
    for (int i = 1; std::getline(in, current); ++i) {
      out += (i == n ? line : current) + "\n";
    }
    WriteCsv(out);
  }

  std::string csv_;
};

TEST_F(RunLogReaderTest, ReadsWhatWasWritten) {
  RunLog log;
  const Status status = ReadRunLog(Csv(), &log);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(log.samples.size(), 5u);
  EXPECT_EQ(log.samples[3].force(0), 30.0);
  EXPECT_EQ(log.samples[4].y(0), 4e-6);
  EXPECT_EQ(log.metadata.rate, 1000.0);
}

TEST_F(RunLogReaderTest, MissingColumn) {
  ReplaceLine(1, "t,Fx,Fy,Fz,x,y,z,toe,camber");
  EXPECT_NE(Error().find(":1: missing column 'caster'"), std::string::npos);
}

TEST_F(RunLogReaderTest, PartialForceColumns) {
  ReplaceLine(1, "t,Fx,Fy,x,y,z,toe,camber,caster,Fz_extra");
  EXPECT_NE(Error().find(":1: Fx, Fy, Fz must appear together"),
            std::string::npos);
}

TEST_F(RunLogReaderTest, NonMonotonicTime) {
  ReplaceLine(4, "0.001,20,-5,0,2e-06,2e-06,3e-06,1e-05,2e-05,3e-05");
  EXPECT_NE(Error().find(":4: time 0.001 s does not increase"),
            std::string::npos);
}

TEST_F(RunLogReaderTest, NanRow) {
  ReplaceLine(3, "0.001,10,-5,0,nan,2e-06,3e-06,1e-05,2e-05,3e-05");
  EXPECT_NE(Error().find(":3: column 'x': not a finite number ('nan')"),
            std::string::npos);
}

TEST_F(RunLogReaderTest, TruncatedFile) {
  WriteCsv(csv_.substr(0, csv_.size() - 7));
  EXPECT_NE(Error().find(":6: truncated"), std::string::npos);
}

TEST_F(RunLogReaderTest, ShortRow) {
  ReplaceLine(5, "0.003,30,-5");
  EXPECT_NE(Error().find(":5: expected 10 fields, got 3"), std::string::npos);
}

TEST_F(RunLogReaderTest, EmptyFile) {
  WriteCsv("");
  EXPECT_NE(Error().find(": empty file"), std::string::npos);
}

TEST_F(RunLogReaderTest, HeaderOnly) {
  WriteCsv("t,Fx,Fy,Fz,x,y,z,toe,camber,caster\n");
  EXPECT_NE(Error().find(": fewer than 2 samples"), std::string::npos);
}

TEST_F(RunLogReaderTest, MissingSidecar) {
  fs::remove(dir_ / "run.json");
  EXPECT_NE(Error().find("run.json: cannot open"), std::string::npos);
}

TEST_F(RunLogReaderTest, SidecarWithOtherSampleCount) {
  std::ifstream in(dir_ / "run.json");
  std::stringstream text;
  text << in.rdbuf();
  std::string json = text.str();
  json.replace(json.find("\"samples\": 5"), 12, "\"samples\": 7");
  std::ofstream(dir_ / "run.json") << json;
  EXPECT_NE(Error().find("says 7 samples, the CSV has 5 (mismatched sidecar)"),
            std::string::npos);
}

TEST_F(RunLogReaderTest, SidecarWithOtherRate) {
  std::ifstream in(dir_ / "run.json");
  std::stringstream text;
  text << in.rdbuf();
  std::string json = text.str();
  json.replace(json.find("\"rate_hz\": 1000.0"), 17, "\"rate_hz\": 500.0");
  std::ofstream(dir_ / "run.json") << json;
  EXPECT_NE(Error().find("does not match the CSV's time column"),
            std::string::npos);
}

TEST_F(RunLogReaderTest, MalformedSidecar) {
  std::ofstream(dir_ / "run.json") << "{\"rate_hz\": 10";
  EXPECT_NE(Error().find("run.json: not valid JSON"), std::string::npos);
}

// Hostile sidecars and files: numbers beyond double, a rate that would make
// the estimator simulate for years, a FIFO or a device that never ends, a
// column given twice.
TEST_F(RunLogReaderTest, HostileSidecarsAndFilesAreOneLineErrors) {
  std::ifstream in(dir_ / "run.json");
  std::stringstream text;
  text << in.rdbuf();
  const std::string json = text.str();
  auto with = [&](const std::string& from, const std::string& to) {
    std::string edited = json;
    edited.replace(edited.find(from), from.size(), to);
    std::ofstream(dir_ / "run.json") << edited;
  };
  with("\"rate_hz\": 1000.0", "\"rate_hz\": 1e400");
  EXPECT_NE(Error().find("run.json: not valid JSON"), std::string::npos);
  with("\"rate_hz\": 1000.0", "\"rate_hz\": 1e-7");
  EXPECT_NE(Error().find("rate_hz must be within [1, 100000] Hz"),
            std::string::npos);
  with("\"tf_s\": 0.004", "\"tf_s\": 1e9");
  EXPECT_NE(Error().find("excitation.tf_s must be within (0, 3600] s"),
            std::string::npos);
  // Every field a reader relies on, validated: counts, format, kinds,
  // ranges.
  const struct {
    const char* from;
    const char* to;
    const char* message;
  } fields[] = {
      {"\"samples\": 5", "\"samples\": 1e20",
       "samples must be a whole number >= 0"},
      {"\"samples\": 5", "\"samples\": -5",
       "samples must be a whole number >= 0"},
      {"\"format\": \"kcrig run log 1\"", "\"format\": \"kcrig run log 99\"",
       "format \"kcrig run log 99\": this kcrig reads \"kcrig run log 1\""},
      {"\"type\": \"linear_ramp\"", "\"type\": \"sine\"",
       "excitation.type \"sine\": only \"linear_ramp\" is known"},
      {"\"fmax_n\": ", "\"fmax_n\": -4000, \"x\": ",
       "excitation.fmax_n must be within [0, 100000] N"},
      {"\"phi_rad\": ", "\"phi_rad\": 1e308, \"x\": ",
       "excitation.phi_rad must be within [-2 pi, 2 pi]"},
  };
  for (const auto& f : fields) {
    with(f.from, f.to);
    EXPECT_NE(Error().find(f.message), std::string::npos)
        << f.to << ": " << Error();
  }
  std::ofstream(dir_ / "run.json") << json;
  ReplaceLine(1, "t,Fx,Fy,Fz,x,y,z,toe,camber,caster,x");
  EXPECT_NE(Error().find(":1: column 'x' appears twice"), std::string::npos);
  fs::remove(Csv());
  ASSERT_EQ(mkfifo(Csv().c_str(), 0600), 0);
  EXPECT_NE(Error().find("run.csv: not a regular file"), std::string::npos);
  RunLog log;
  const Status device = ReadRunLog("/dev/zero", &log);
  EXPECT_NE(device.message().find("/dev/zero: not a regular file"),
            std::string::npos)
      << device.message();
}

}  // namespace
}  // namespace kcrig
