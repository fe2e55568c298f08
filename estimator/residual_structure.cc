#include "estimator/residual_structure.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "Eigen/Eigenvalues"

namespace kcrig {
namespace {

constexpr int kShortestBlock = 32;
constexpr int kFewestBlocksPerLog = 10;
constexpr int kFewestDegreesOfFreedom = 5;
// Standard deviations of the sandwich's variance (relative sd
// sqrt(2 / dof)) by which it must exceed the classical one to replace it.
constexpr double kWidenBeyond = 2;

// Where each log's rows start, and its samples; one entry past the end.
struct LogRows {
  std::vector<Eigen::Index> first_row;
  std::vector<int> samples;
};

LogRows LayOut(const std::vector<Experiment>& experiments, int num_channels) {
  LogRows rows;
  Eigen::Index row = 0;
  for (const Experiment& e : experiments) {
    rows.first_row.push_back(row);
    rows.samples.push_back(static_cast<int>(e.measured.size()));
    row += static_cast<Eigen::Index>(e.measured.size()) * num_channels;
  }
  return rows;
}

// One point of the blocking curve: the residual's block sums of `length`
// samples (full blocks only), per channel, against white noise's.
struct BlockingPoint {
  int length = 0;
  int blocks = 0;
  double ratio = 1;
};

BlockingPoint Blocking(const Eigen::VectorXd& residuals, const LogRows& rows,
                       int num_channels, int length) {
  BlockingPoint point;
  point.length = length;
  double sum_of_squared_sums = 0, sum_of_squares = 0;
  for (size_t l = 0; l < rows.samples.size(); ++l) {
    const int blocks = rows.samples[l] / length;
    point.blocks += blocks;
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

// The longest block (from kShortestBlock, doubling) that leaves every log
// kFewestBlocksPerLog blocks: a residual correlated over much less than a
// block adds nothing to the spread of its sums but its variance; fewer,
// noisier blocks are paid for by Student's quantile.
BlockingPoint ChooseBlock(const Eigen::VectorXd& residuals, const LogRows& rows,
                          int num_channels) {
  const int shortest_log =
      *std::min_element(rows.samples.begin(), rows.samples.end());
  int length = kShortestBlock;
  while (2 * length <= shortest_log / kFewestBlocksPerLog) length *= 2;
  return Blocking(residuals, rows, num_channels, length);
}

// Student's t quantile for two-sided 95 % at `dof` degrees of freedom over
// the normal's (Cornish-Fisher to 1 / dof^2; within 0.1 % from 5 dof).
double StudentOverNormal95(double dof) {
  constexpr double z = 1.959963984540054;
  const double z3 = z * z * z, z5 = z3 * z * z;
  const double t =
      z + (z3 + z) / (4 * dof) + (5 * z5 + 16 * z3 + 3 * z) / (96 * dof * dof);
  return t / z;
}

// (J^T J)^+ on the identifiable subspace: the `rank` largest eigenvalues of
// the information.
Eigen::MatrixXd IdentifiableInverse(const Eigen::MatrixXd& information,
                                    int rank) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(information);
  const int n = static_cast<int>(information.rows());
  Eigen::MatrixXd inverse = Eigen::MatrixXd::Zero(n, n);
  for (int i = n - rank; i < n; ++i) {
    const Eigen::VectorXd v = eigen.eigenvectors().col(i);
    inverse += v * v.transpose() / eigen.eigenvalues()(i);
  }
  return inverse;
}

}  // namespace

ResidualStructure MeasureResidualStructure(
    const Eigen::MatrixXd& jacobian, const Eigen::VectorXd& residuals,
    const std::vector<Experiment>& experiments, int num_channels) {
  ResidualStructure structure;
  const int n = static_cast<int>(jacobian.cols());
  if (experiments.empty() || residuals.size() != jacobian.rows()) {
    return structure;
  }
  const LogRows rows = LayOut(experiments, num_channels);
  const BlockingPoint block = ChooseBlock(residuals, rows, num_channels);
  structure.block_samples = block.length;
  structure.correlation = block.ratio;
  structure.meat = Eigen::MatrixXd::Zero(n, n);
  // Every row in a block: a log's trailing part joins its last block.
  for (size_t l = 0; l < rows.samples.size(); ++l) {
    const int blocks = std::max(1, rows.samples[l] / block.length);
    Eigen::VectorXd previous;
    for (int b = 0; b < blocks; ++b) {
      const Eigen::Index first =
          rows.first_row[l] + Eigen::Index(b) * block.length * num_channels;
      const Eigen::Index end =
          b + 1 < blocks ? first + Eigen::Index(block.length) * num_channels
                         : rows.first_row[l] +
                               Eigen::Index(rows.samples[l]) * num_channels;
      const Eigen::VectorXd g =
          jacobian.middleRows(first, end - first).transpose() *
          residuals.segment(first, end - first);
      structure.meat += g * g.transpose();
      if (b > 0) {
        structure.meat +=
            0.5 * (g * previous.transpose() + previous * g.transpose());
      }
      previous = g;
      ++structure.num_blocks;
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
      result->rank == 0) {
    return;
  }
  const Eigen::MatrixXd inverse =
      IdentifiableInverse(result->information, result->rank);
  const Eigen::MatrixXd sandwich =
      inverse * structure.meat * inverse * (structure.num_blocks / double(dof));
  const double quantile = StudentOverNormal95(dof);
  // White noise leaves the sandwich within its sampling spread of the
  // classical variance: the classical intervals stand.
  const double significant = 1 + kWidenBeyond * std::sqrt(2.0 / dof);
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
