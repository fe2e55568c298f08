#include "rt_core/model/model_config.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include "gtest/gtest.h"
#include "tests/support/temp_dir_test.h"

namespace kcrig {
namespace {

namespace fs = std::filesystem;

std::string ReadFile(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

// A copy of the source config/ in a fresh directory, with one text
// replacement applied to one file.
class ConfigLoaderTest : public TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    for (const char* file : {"model.yaml", "experiment.yaml"}) {
      fs::copy_file(fs::path(KCRIG_TEST_CONFIG_DIR) / file, dir_ / file);
    }
  }

  // Returns the 1-based line of the replacement.
  int Replace(const std::string& file, const std::string& from,
              const std::string& to) {
    std::string text = ReadFile(dir_ / file);
    const size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at == std::string::npos) return 0;
    text.replace(at, from.size(), to);
    std::ofstream(dir_ / file) << text;
    return 1 +
           static_cast<int>(std::count(text.begin(), text.begin() + at, '\n'));
  }

  std::string LoadError() {
    KcrigConfig config;
    const Status status = LoadConfig(dir_.string(), &config);
    EXPECT_FALSE(status.ok());
    EXPECT_EQ(status.message().find('\n'), std::string::npos)
        << "error must be one line";
    return status.message();
  }
};

TEST_F(ConfigLoaderTest, SourceConfigLoads) {
  KcrigConfig config;
  const Status status = LoadConfig(dir_.string(), &config);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_DOUBLE_EQ(config.model.bushings[kO1].stiffness, 4.0e6);
  EXPECT_DOUBLE_EQ(config.model.mass, 47.0);
  EXPECT_NEAR(config.experiment.phi, 85.0 * M_PI / 180.0, 1e-15);
  EXPECT_DOUBLE_EQ(config.experiment.z_a, -0.45);
  EXPECT_NEAR(config.experiment.sigma_angle, 0.01 * M_PI / 180.0, 1e-18);
  EXPECT_DOUBLE_EQ(config.experiment.sigma_position, 2e-5);
}

TEST_F(ConfigLoaderTest, MissingKeyNamesFileLineAndKey) {
  Replace("model.yaml", "    stiffness: 4.0e6          # [N/m]\n", "");
  const std::string error = LoadError();
  EXPECT_TRUE(std::regex_search(
      error,
      std::regex(
          R"(model\.yaml:[0-9]+: bushings\.O1\.stiffness: missing key)")))
      << error;
}

TEST_F(ConfigLoaderTest, WrongTypeNamesTheValue) {
  const int line = Replace("model.yaml", "mass: 47.0", "mass: heavy");
  EXPECT_NE(LoadError().find("model.yaml:" + std::to_string(line) +
                             ": mass: expected a number, got 'heavy'"),
            std::string::npos);
}

TEST_F(ConfigLoaderTest, NegativeMassIsRejected) {
  Replace("model.yaml", "mass: 47.0", "mass: -47.0");
  const std::string error = LoadError();
  EXPECT_NE(error.find("model.yaml: mass: must be within (0, 1e4] kg"),
            std::string::npos)
      << error;
}

TEST_F(ConfigLoaderTest, ValuesBeyondAnySuspensionAreRejected) {
  Replace("model.yaml", "mass: 47.0", "mass: 1e308");
  EXPECT_NE(LoadError().find("mass: must be within (0, 1e4] kg"),
            std::string::npos);
}

TEST_F(ConfigLoaderTest, DegenerateLinkIsRejected) {
  Replace("model.yaml", "chassis: [0.150, 0.305, 0.064]",
          "chassis: [0.038, 0.112, 0.066]");
  const std::string error = LoadError();
  EXPECT_NE(error.find("bushings.O2: degenerate link"), std::string::npos)
      << error;
}

TEST_F(ConfigLoaderTest, NanValueNamesFileLineAndKey) {
  const int line = Replace("model.yaml", "stiffness: 1.1e5", "stiffness: .nan");
  EXPECT_NE(LoadError().find("model.yaml:" + std::to_string(line) +
                             ": spring.stiffness: must be finite"),
            std::string::npos);
}

TEST_F(ConfigLoaderTest, ShortVectorIsRejected) {
  Replace("model.yaml", "inertia: [1.1, 1.7, 1.1]", "inertia: [1.1, 1.7]");
  const std::string error = LoadError();
  EXPECT_NE(error.find("inertia: expected a list of 3 numbers"),
            std::string::npos)
      << error;
}

TEST_F(ConfigLoaderTest, MalformedYamlNamesTheLine) {
  Replace("experiment.yaml", "  rate: 1000.0", "  rate: [1000.0");
  const std::string error = LoadError();
  EXPECT_TRUE(std::regex_search(
      error, std::regex(R"(experiment\.yaml:[0-9]+: malformed YAML)")))
      << error;
}

TEST_F(ConfigLoaderTest, NonPositiveSigmaIsRejected) {
  Replace("experiment.yaml", "sigma_position: 2.0e-5", "sigma_position: 0");
  const std::string error = LoadError();
  EXPECT_TRUE(std::regex_search(
      error,
      std::regex(
          R"(experiment\.yaml:[0-9]+: measurement\.sigma_position: must be within \(0, 0\.1\])")))
      << error;
}

TEST_F(ConfigLoaderTest, InvertedBoundsAreRejected) {
  Replace("experiment.yaml", "phi_deg: [0.0, 90.0]", "phi_deg: [90.0, 0.0]");
  EXPECT_NE(LoadError().find("design_bounds.phi_deg: lower bound"),
            std::string::npos);
}

TEST_F(ConfigLoaderTest, MissingFileIsNamed) {
  fs::remove(dir_ / "experiment.yaml");
  EXPECT_NE(LoadError().find("experiment.yaml: cannot open"),
            std::string::npos);
}

TEST(ValidateModelTest, NanParameterIsRejected) {
  KcrigConfig config;
  ASSERT_TRUE(LoadConfig(KCRIG_TEST_CONFIG_DIR, &config).ok());
  config.model.bushings[kP].damping = std::nan("");
  const Status status = ValidateModel(config.model, "--set");
  EXPECT_FALSE(status.ok());
  EXPECT_EQ(status.message(), "--set: d_P: must be finite");
}

}  // namespace
}  // namespace kcrig
