// Intervals that hold when the residual is not white noise. The classical
// covariance sigma_hat^2 (J^T J)^-1 assumes independent residuals. A model
// that leaves structure (an effect of another form than the rig's, a rig
// that filters its sensors) has residuals correlated over many samples, and
// its classical intervals are too narrow by about the square root of the
// correlation length: a +-0.3 % interval around a value 30 % off. The
// sandwich (J^T J)^-1 M (J^T J)^-1, with M the spread of the gradient J^T r
// over contiguous blocks of each log and its neighbours' (batch means:
// Newey and West's estimator over block sums, Bartlett's weights), holds
// for a correlation shorter than a block.
#ifndef KCRIG_ESTIMATOR_RESIDUAL_STRUCTURE_H_
#define KCRIG_ESTIMATOR_RESIDUAL_STRUCTURE_H_

#include <vector>

#include "Eigen/Core"
#include "estimator/estimator.h"
#include "estimator/experiment.h"

namespace kcrig {

struct ResidualStructure {
  // Blocks of each log's data (its memory rows left out), the longest of
  // 32, 64, ... samples that leaves every log ten blocks and all logs
  // together the parameters' number and five more (32 when even those are
  // too many).
  int num_blocks = 0;
  // The variance of a block's residual sum over white noise's of the same
  // variance at that length: 1 for white noise, about twice the integrated
  // correlation time [samples] otherwise.
  double correlation = 1;
  // M = sum over blocks b of g_b g_b^T + (g_b g_{b-1}^T + g_{b-1} g_b^T) / 2
  // within a log, g_b = J_b^T r_b less their mean (a parameter held on its
  // bound leaves a gradient that is not the residual's structure), in
  // scaled parameters. Empty when the rows do not match the logs' layout.
  Eigen::MatrixXd meat;
};

// From the weighted Jacobian (scaled parameters) and residuals at a
// solution, laid out as SplitResiduals takes them, `num_channels` rows per
// sample. Call before AnalyzeUncertainty, which consumes J.
ResidualStructure MeasureResidualStructure(
    const Eigen::MatrixXd& jacobian, const Eigen::VectorXd& residuals,
    const std::vector<Experiment>& experiments, int num_channels);

// After AnalyzeUncertainty, before AddDiscretisationBias: a determined
// parameter whose sandwich variance (times B / (B - k), B blocks, rank k)
// exceeds the classical one by more than two standard deviations of its own
// sampling spread, about sqrt(3 / (B - k)), gets the sandwich's standard
// error times Student's quantile at B - k degrees of freedom over the
// normal's, and its interval with it; white noise keeps the classical
// intervals, which a sandwich from few blocks would only blur. Fewer than
// five degrees of freedom (a short log, many parameters): not checked, the
// classical intervals stand. The covariance keeps its correlations; the
// information matrix (the data's, for a design's prior) stays classical.
// Records the largest widening (EstimationResult::interval_widening) and
// the correlation.
void WidenForResidualStructure(const ResidualStructure& structure,
                               EstimationResult* result);

}  // namespace kcrig

#endif  // KCRIG_ESTIMATOR_RESIDUAL_STRUCTURE_H_
