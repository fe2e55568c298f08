// Model adequacy: whether a fitted model explains the data down to the
// stated sensor noise. A model that is wrong can still fit well by biasing
// its parameters; what it cannot hide is a residual larger than the noise
// (chi-square against the sensor sigmas) or one with structure in time
// (Ljung-Box whiteness per channel). Every fit states both, and so does the
// prediction of a log the fit has not seen (a hold-out), where an effect
// absorbed by biased parameters shows.
#ifndef KCRIG_ESTIMATOR_ADEQUACY_H_
#define KCRIG_ESTIMATOR_ADEQUACY_H_

#include <array>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "estimator/experiment.h"

namespace kcrig {

// Every channel, x .. caster: what the diagnosis' effect models fit.
inline const std::vector<int> kAllChannels = {0, 1, 2, 3, 4, 5};

struct AdequacyOptions {
  // A test whose p-value is below this says `inadequate`. Small, because
  // the residual counts are large and a false alarm costs a diagnosis run.
  double significance = 1e-3;
  // Autocorrelation lags of the Ljung-Box test.
  int ljung_box_lags = 20;
};

struct ChannelAdequacy {
  bool used = false;
  double score = 0;        // mean (r / sigma)^2; 1 is the sensor noise
  double whiteness_p = 1;  // Ljung-Box, Bonferroni over the logs
  long samples = 0;
  // RMS of the model's own discretisation error [sigma]; the tests above
  // are on the residual without it (0 where not estimated).
  double discretisation = 0;
};

struct Adequacy {
  bool assessed = false;
  double chi_square = 0;  // sum of (r / sigma)^2 over the residuals
  double dof = 0;         // residuals - fitted parameters
  double p_value = 1;     // P(chi-square with dof > chi_square)
  double score = 0;       // mean (r / sigma)^2; 1 is the noise
  // Ljung-Box over every used channel of every log, Bonferroni-corrected.
  double whiteness_p = 1;
  std::array<ChannelAdequacy, 6> channels;  // x, y, z, toe, camber, caster
  bool adequate = true;
  // Why not, in one line ("" when adequate).
  std::string reason;
  // The largest per-channel RMS of the model's discretisation error
  // [sigma] (AddDiscretisationError; 0 where not estimated), and whether
  // the residual judged is the model's continuous-time limit's (the
  // discretisation error set apart) rather than the model's at its step.
  double discretisation = 0;
  bool continuous_limit = false;
};

// Assesses the weighted residuals weighted[l][j] = (model - measured) /
// sigma of log l, sample j (unobserved samples skipped) over `channels`
// (indices into x..caster) of a model with `fitted_parameters` fitted to
// them (0 for a prediction).
Adequacy AssessAdequacy(const std::vector<Experiment>& logs,
                        const std::vector<std::vector<Vec6<double>>>& weighted,
                        const std::vector<int>& channels, int fitted_parameters,
                        const AdequacyOptions& options);

// The adequacy of a prediction by an estimate with information I (J^T J of
// its fit): `predicted` are the weighted prediction residuals r, and
// `decorrelated` (I + J C J^T)^-1 r with J the prediction's sensitivities
// and C = I^-1, the part the estimate's own uncertainty explains removed.
// Under a correct model r ~ N(0, I + J C J^T): the chi-square is
// r . decorrelated with one degree of freedom per residual, whiteness is
// tested on the decorrelated residual, and the scores per channel are the
// raw prediction's (mean (r / sigma)^2).
Adequacy AssessPrediction(
    const std::vector<Experiment>& logs,
    const std::vector<std::vector<Vec6<double>>>& predicted,
    const std::vector<std::vector<Vec6<double>>>& decorrelated,
    const std::vector<int>& channels, const AdequacyOptions& options);

// AssessPrediction from a least-squares problem's residual vector r and
// Jacobian J on the predicted logs (laid out as SplitResiduals takes them)
// and the information I of the estimate that predicts them, in the same
// parameters: the decorrelated residual r - J (I + J^T J)^+ J^T r.
Adequacy AssessPredictionResiduals(const std::vector<Experiment>& logs,
                                   const std::vector<int>& channels,
                                   const Eigen::VectorXd& residuals,
                                   const Eigen::MatrixXd& jacobian,
                                   const Eigen::MatrixXd& information,
                                   const AdequacyOptions& options);

// Records the model's discretisation error (weighted, per log and sample)
// per channel and its largest channel RMS in `adequacy`.
void AddDiscretisationError(const std::vector<Experiment>& logs,
                            const std::vector<std::vector<Vec6<double>>>& error,
                            Adequacy* adequacy);

// The model judged at its step (`at_step`) or at its continuous-time limit
// (`limit`: the same test on the residual less the discretisation error),
// whichever explains the data better: data from the model's own scheme are
// matched by the former, a continuous rig by the latter. The chosen one,
// with the discretisation error (weighted, per log and sample) recorded.
Adequacy BetterOfStepAndLimit(
    Adequacy at_step, Adequacy limit, const std::vector<Experiment>& logs,
    const std::vector<std::vector<Vec6<double>>>& discretisation);

// A least-squares residual vector laid out (experiment, sample, channel of
// `channels`) as weighted[l][j](k), zero in the channels not in it.
std::vector<std::vector<Vec6<double>>> SplitResiduals(
    const std::vector<Experiment>& experiments,
    const std::vector<int>& channels, const Eigen::VectorXd& residuals);

// Residual RMS per channel over the observed samples, in SI units (m, rad).
Vec6<double> ResidualRms(
    const std::vector<Experiment>& experiments,
    const std::vector<std::vector<Vec6<double>>>& weighted);

// The Ljung-Box whiteness p-value of `channels` over all logs: the smallest
// per-channel, per-log p, Bonferroni-corrected for their number.
double WhitenessP(const std::vector<Experiment>& logs,
                  const std::vector<std::vector<Vec6<double>>>& weighted,
                  const std::vector<int>& channels, int lags);

// Ljung-Box Q of one residual series.
double LjungBox(const std::vector<double>& x, int lags);

// P(chi-square with `dof` degrees of freedom > x): the regularized upper
// incomplete gamma Q(dof/2, x/2).
double ChiSquareUpperTail(double x, double dof);

}  // namespace kcrig

#endif  // KCRIG_ESTIMATOR_ADEQUACY_H_
