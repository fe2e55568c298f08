// The intervals widened for a correlated residual (residual_structure.h):
// a straight-line fit to data with AR(1) noise, whose classical intervals
// assume independent samples, and to white noise, where they hold.
#include "estimator/residual_structure.h"

#include <cmath>
#include <random>

#include "gtest/gtest.h"

namespace kcrig {
namespace {

constexpr int kSamples = 4000;
constexpr int kLogs = 3;
constexpr int kReplicates = 300;

struct Coverage {
  double classical = 0, widened = 0, mean_widening = 0;
};

// y = a + b t + e with e AR(1) of coefficient `rho` and unit variance, fitted
// by least squares (unit weights), over kReplicates noise draws.
Coverage StraightLineCoverage(double rho) {
  std::mt19937 random(7);
  std::normal_distribution<double> normal;
  const int rows = kSamples * kLogs;
  Eigen::MatrixXd jacobian(rows, 2);
  for (int r = 0; r < rows; ++r) {
    jacobian(r, 0) = 1;
    jacobian(r, 1) = double(r % kSamples) / kSamples;
  }
  std::vector<Experiment> logs(kLogs);
  for (Experiment& log : logs) log.measured.resize(kSamples);
  Coverage coverage;
  for (int k = 0; k < kReplicates; ++k) {
    Eigen::VectorXd noise(rows);
    for (int r = 0; r < rows; ++r) {
      const double innovation = normal(random) * std::sqrt(1 - rho * rho);
      noise(r) =
          r % kSamples == 0 ? normal(random) : rho * noise(r - 1) + innovation;
    }
    // Truth a = b = 0: the fit is the projection of the noise.
    const Eigen::VectorXd fit = jacobian.colPivHouseholderQr().solve(noise);
    const Eigen::VectorXd residuals = noise - jacobian * fit;
    EstimationResult result;
    for (int i = 0; i < 2; ++i) {
      ParameterEstimate p;
      p.name = i == 0 ? "a" : "b";
      p.nominal = 1;
      p.value = fit(i);
      result.parameters.push_back(p);
    }
    result.sigma_hat = std::sqrt(residuals.squaredNorm() / (rows - 2));
    const ResidualStructure structure =
        MeasureResidualStructure(jacobian, residuals, logs, 1);
    AnalyzeUncertainty(jacobian, EstimatorOptions(), &result);
    std::vector<bool> inside_before;
    for (const ParameterEstimate& p : result.parameters) {
      inside_before.push_back(p.ci95_low <= 0 && 0 <= p.ci95_high);
    }
    WidenForResidualStructure(structure, &result);
    for (int i = 0; i < 2; ++i) {
      const ParameterEstimate& p = result.parameters[i];
      coverage.classical += inside_before[i];
      coverage.widened += p.ci95_low <= 0 && 0 <= p.ci95_high;
    }
    coverage.mean_widening += result.interval_widening;
  }
  coverage.classical /= 2.0 * kReplicates;
  coverage.widened /= 2.0 * kReplicates;
  coverage.mean_widening /= kReplicates;
  return coverage;
}

TEST(ResidualStructureTest, CorrelatedNoiseGetsIntervalsThatCover) {
  const Coverage c = StraightLineCoverage(0.9);
  EXPECT_LT(c.classical, 0.6) << "the classical intervals should fail here";
  EXPECT_GE(c.widened, 0.90);
  EXPECT_LE(c.widened, 0.99);
  EXPECT_GT(c.mean_widening, 3);  // sqrt((1 + rho) / (1 - rho)) = 4.4
}

TEST(ResidualStructureTest, WhiteNoiseKeepsItsClassicalIntervals) {
  const Coverage c = StraightLineCoverage(0);
  EXPECT_GE(c.widened, 0.93);
  EXPECT_LE(c.widened, 0.985);
  // Only a sandwich beyond two standard deviations of its own spread
  // widens: a few draws in a hundred, by a third or so.
  EXPECT_LT(c.mean_widening, 1.05);
}

// A residual that flips sign every 32 samples beside a constant column
// would widen the interval (its block sums are all the residual) but for
// too few blocks: one log of 96 samples gives three, too few for the one
// parameter's sandwich.
TEST(ResidualStructureTest, TooFewBlocksWidenNothing) {
  constexpr int kShort = 96;
  const Eigen::MatrixXd jacobian = Eigen::MatrixXd::Ones(kShort, 1);
  Eigen::VectorXd residuals(kShort);
  for (int r = 0; r < kShort; ++r) residuals(r) = (r / 32) % 2 ? -1 : 1;
  std::vector<Experiment> logs(1);
  logs[0].measured.resize(kShort);
  const ResidualStructure structure =
      MeasureResidualStructure(jacobian, residuals, logs, 1);
  EXPECT_EQ(structure.num_blocks, 3);
  EstimationResult result;
  result.parameters.push_back({});
  result.parameters[0].nominal = 1;
  result.sigma_hat = 1;
  AnalyzeUncertainty(jacobian, EstimatorOptions(), &result);
  const double before = result.parameters[0].standard_error;
  WidenForResidualStructure(structure, &result);
  EXPECT_EQ(result.parameters[0].standard_error, before);
  EXPECT_EQ(result.interval_widening, 1);
}

// Rows laid out sample by sample, channels within (SplitResiduals), with
// the memory rows of a rig log left out and a parameter of nominal 2:
// the same widening as one channel without memory, the interval in the
// parameter's units.
TEST(ResidualStructureTest, ChannelsMemoryRowsAndScaleAreLaidOutAsTheFit) {
  std::mt19937 random(3);
  std::normal_distribution<double> normal;
  constexpr int kMemory = 500, kData = 4000, kChannels = 2;
  std::vector<Experiment> logs(1);
  logs[0].measured.resize(kMemory + kData);
  logs[0].memory_rows = kMemory;
  const int rows = (kMemory + kData) * kChannels;
  Eigen::MatrixXd jacobian = Eigen::MatrixXd::Zero(rows, 1);
  Eigen::VectorXd residuals = Eigen::VectorXd::Zero(rows);
  double noise = 0;
  for (int j = kMemory; j < kMemory + kData; ++j) {
    noise = 0.95 * noise + std::sqrt(1 - 0.95 * 0.95) * normal(random);
    jacobian(j * kChannels, 0) = 1;  // channel 0 carries the parameter
    residuals(j * kChannels) = noise;
    residuals(j * kChannels + 1) = normal(random);  // channel 1 white
  }
  residuals.segment(kMemory * kChannels, kData * kChannels).array() -=
      residuals.segment(kMemory * kChannels, kData * kChannels).mean();
  const ResidualStructure structure =
      MeasureResidualStructure(jacobian, residuals, logs, kChannels);
  EXPECT_GE(structure.num_blocks, 10);
  EstimationResult result;
  result.parameters.push_back({});
  result.parameters[0].nominal = 2;
  result.parameters[0].value = 2;
  result.sigma_hat = 1;
  AnalyzeUncertainty(jacobian, EstimatorOptions(), &result);
  const double classical = result.parameters[0].standard_error;
  EXPECT_NEAR(classical, 2 / std::sqrt(double(kData)), 1e-9);
  WidenForResidualStructure(structure, &result);
  // AR(1) at 0.95: the mean's standard error sqrt(39) = 6.2 times wider.
  EXPECT_GT(result.interval_widening, 3.5);
  EXPECT_LT(result.interval_widening, 10);
  EXPECT_NEAR(result.parameters[0].ci95_high - 2,
              1.959963984540054 * result.parameters[0].standard_error, 1e-9);
}

}  // namespace
}  // namespace kcrig
