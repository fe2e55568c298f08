#include "estimator/residual_structure.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace kcrig {
namespace {

constexpr int kShortestBlock = 32;
constexpr int kFewestBlocksPerLog = 10;
constexpr int kFewestDegreesOfFreedom = 5;
// Standard deviations of the sandwich's variance (relative sd about
// sqrt(3 / dof) with the neighbours' terms) by which it must exceed the
// classical one to replace it.
constexpr double kWidenBeyond = 2;

// Per log, the row its data start at (after its memory rows, which carry
// no data) and its samples from there.
struct LogRows {
  std::vector<Eigen::Index> first_row;
  std::vector<int> samples;
  Eigen::Index total_rows = 0;
};

LogRows LayOut(const std::vector<Experiment>& experiments, int num_channels) {
  LogRows rows;
  for (const Experiment& e : experiments) {
    const int size = static_cast<int>(e.measured.size());
    const int skipped = std::clamp(e.memory_rows, 0, size);
    rows.first_row.push_back(rows.total_rows +
                             Eigen::Index(skipped) * num_channels);
    rows.samples.push_back(size - skipped);
    rows.total_rows += Eigen::Index(size) * num_channels;
  }
  return rows;
}

// One point of the blocking curve: the residual's block sums of `length`
// samples (full blocks only), per channel, against white noise's.
struct BlockingPoint {
  int length = 0;
  double ratio = 1;
};

BlockingPoint Blocking(const Eigen::VectorXd& residuals, const LogRows& rows,
                       int num_channels, int length) {
  BlockingPoint point;
  point.length = length;
  double sum_of_squared_sums = 0, sum_of_squares = 0;
  for (size_t l = 0; l < rows.samples.size(); ++l) {
    const int blocks = rows.samples[l] / length;
    for (int b = 0; b < blocks; ++b) {
      const Eigen::Index first =
          rows.first_row[l] + Eigen::Index(b) * length * num_channels;
      for (int k = 0; k < num_channels; ++k) {
        double sum = 0;
        for (int j = 0; j < length; ++j) {
          const double r =
              residuals(first + Eigen::Index(j) * num_channels + k);
          sum += r;
          sum_of_squares += r * r;
        }
        sum_of_squared_sums += sum * sum;
      }
    }
  }
  point.ratio = sum_of_squares > 0 ? sum_of_squared_sums / sum_of_squares : 1;
  return point;
}

int CountBlocks(const LogRows& rows, int length) {
  int blocks = 0;
  for (int samples : rows.samples) blocks += std::max(1, samples / length);
  return blocks;
}

// The longest block (from kShortestBlock, doubling) that leaves every log
// kFewestBlocksPerLog blocks and all logs together `fewest_blocks`: a
// residual correlated over much less than a block adds nothing to the
// spread of its sums but its variance; fewer, noisier blocks are paid for
// by Student's quantile.
BlockingPoint ChooseBlock(const Eigen::VectorXd& residuals, const LogRows& rows,
                          int num_channels, int fewest_blocks) {
  const int shortest_log =
      *std::min_element(rows.samples.begin(), rows.samples.end());
  int length = kShortestBlock;
  while (2 * length <= shortest_log / kFewestBlocksPerLog &&
         CountBlocks(rows, 2 * length) >= fewest_blocks) {
    length *= 2;
  }
  return Blocking(residuals, rows, num_channels, length);
}

// Student's t quantile for two-sided 95 % at `dof` degrees of freedom over
// the normal's (Cornish-Fisher to 1 / dof^2: 1 % low at 5 dof, within
// 0.1 % from 11).
double StudentOverNormal95(double dof) {
  constexpr double z = kZ95;
  const double z3 = z * z * z, z5 = z3 * z * z;
  const double t =
      z + (z3 + z) / (4 * dof) + (5 * z5 + 16 * z3 + 3 * z) / (96 * dof * dof);
  return t / z;
}

// (J^T J)^+ in scaled parameters, from the classical covariance
// sigma_hat^2 S (J^T J)^+ S that AnalyzeUncertainty computed through the
// SVD of J's R factor (eigenvalues of J^T J itself would square its
// condition number).
Eigen::MatrixXd ScaledInverseInformation(const EstimationResult& result) {
  const int n = static_cast<int>(result.parameters.size());
  Eigen::VectorXd inverse_scale(n);
  for (int i = 0; i < n; ++i) {
    inverse_scale(i) = 1 / result.parameters[i].nominal;
  }
  return inverse_scale.asDiagonal() * result.covariance *
         inverse_scale.asDiagonal() / (result.sigma_hat * result.sigma_hat);
}

}  // namespace

ResidualStructure MeasureResidualStructure(
    const Eigen::MatrixXd& jacobian, const Eigen::VectorXd& residuals,
    const std::vector<Experiment>& experiments, int num_channels) {
  ResidualStructure structure;
  const int n = static_cast<int>(jacobian.cols());
  const LogRows rows = LayOut(experiments, num_channels);
  if (experiments.empty() || residuals.size() != jacobian.rows() ||
      rows.total_rows != residuals.size()) {
    return structure;
  }
  const BlockingPoint block =
      ChooseBlock(residuals, rows, num_channels, n + kFewestDegreesOfFreedom);
  structure.correlation = block.ratio;
  // Every row of data in a block: a log's trailing part joins its last.
  std::vector<Eigen::VectorXd> gradients;
  std::vector<bool> follows;  // the block follows another of its log
  for (size_t l = 0; l < rows.samples.size(); ++l) {
    const int blocks = std::max(1, rows.samples[l] / block.length);
    const Eigen::Index log_end =
        rows.first_row[l] + Eigen::Index(rows.samples[l]) * num_channels;
    for (int b = 0; b < blocks; ++b) {
      const Eigen::Index first =
          rows.first_row[l] + Eigen::Index(b) * block.length * num_channels;
      const Eigen::Index end =
          b + 1 < blocks ? first + Eigen::Index(block.length) * num_channels
                         : log_end;
      gradients.push_back(jacobian.middleRows(first, end - first).transpose() *
                          residuals.segment(first, end - first));
      follows.push_back(b > 0);
    }
  }
  structure.num_blocks = static_cast<int>(gradients.size());
  structure.meat = Eigen::MatrixXd::Zero(n, n);
  if (gradients.empty()) return structure;
  // Centred: at a parameter held on its bound the total gradient is not
  // zero, and its share in every block is not the residual's structure.
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(n);
  for (const Eigen::VectorXd& g : gradients) mean += g;
  mean /= double(gradients.size());
  for (size_t b = 0; b < gradients.size(); ++b) {
    const Eigen::VectorXd g = gradients[b] - mean;
    structure.meat += g * g.transpose();
    if (follows[b]) {
      const Eigen::VectorXd previous = gradients[b - 1] - mean;
      structure.meat +=
          0.5 * (g * previous.transpose() + previous * g.transpose());
    }
  }
  return structure;
}

void WidenForResidualStructure(const ResidualStructure& structure,
                               EstimationResult* result) {
  result->residual_correlation = structure.correlation;
  const int n = static_cast<int>(result->parameters.size());
  // Too few blocks for the rank leave the sandwich no degrees of freedom.
  const int dof = structure.num_blocks - result->rank;
  if (dof < kFewestDegreesOfFreedom || structure.meat.rows() != n ||
      result->rank == 0 || !(result->sigma_hat > 0) ||
      result->covariance.rows() != n) {
    return;
  }
  const Eigen::MatrixXd inverse = ScaledInverseInformation(*result);
  const Eigen::MatrixXd sandwich =
      inverse * structure.meat * inverse * (structure.num_blocks / double(dof));
  const double quantile = StudentOverNormal95(dof);
  // White noise leaves the sandwich within its sampling spread of the
  // classical variance: the classical intervals stand.
  const double significant = 1 + kWidenBeyond * std::sqrt(3.0 / dof);
  Eigen::VectorXd widening = Eigen::VectorXd::Ones(n);
  for (int i = 0; i < n; ++i) {
    ParameterEstimate& p = result->parameters[i];
    if (!std::isfinite(p.standard_error) || p.standard_error <= 0) continue;
    const double variance =
        std::max(0.0, sandwich(i, i)) * p.nominal * p.nominal;
    if (variance <= significant * p.standard_error * p.standard_error) {
      continue;
    }
    const double robust = std::sqrt(variance) * quantile;
    widening(i) = robust / p.standard_error;
    p.standard_error = robust;
    const double half = (p.ci95_high - p.ci95_low) / 2 * widening(i);
    p.ci95_low = p.value - half;
    p.ci95_high = p.value + half;
  }
  result->covariance =
      widening.asDiagonal() * result->covariance * widening.asDiagonal();
  result->interval_widening = widening.maxCoeff();
}

}  // namespace kcrig
