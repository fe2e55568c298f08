// est.json (DESIGN.md §4): per parameter value, standard error and 95 %
// interval; covariance, correlation, log10 diag((J^T J)^-1), singular values
// of J; residual RMS per channel; cost, iterations, seconds, convergence.
// Quantities that do not exist (a non-identifiable parameter's standard
// error) are written as null, never as huge numbers.
#ifndef KCRIG_ESTIMATOR_ESTIMATE_IO_H_
#define KCRIG_ESTIMATOR_ESTIMATE_IO_H_

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "base/status.h"
#include "estimator/estimator.h"
#include "estimator/profile_likelihood.h"
#include "nlohmann/json_fwd.hpp"

namespace kcrig {

// Stiffnesses read best in N/mm, everything else in its SI unit: the factor
// from SI to the displayed unit, and that unit.
double DisplayScale(const ParameterEstimate& p);
std::string DisplayUnit(const ParameterEstimate& p);

// One parameter estimate as every result file writes it (est.json's
// parameters, each iteration's in campaign.json, each candidate's and the
// attribution's in diag.json), in SI units: name, unit, nominal, initial,
// value, standard_error, ci95 [low, high], discretisation_bias,
// log10_diag_inv_jtj, identifiable, at_bound; null for what is not finite.
nlohmann::ordered_json ParameterEstimateToJson(const ParameterEstimate& p);
// Parameters [begin, end) of `all` (to its end at most), each as above.
nlohmann::ordered_json ParameterEstimatesToJson(
    const std::vector<ParameterEstimate>& all, size_t begin = 0,
    size_t end = SIZE_MAX);

// Reads one that ParameterEstimateToJson wrote: the name and a finite value
// required, the rest as written (missing or null: not given, so NaN for the
// standard error, interval and log10 diag, 0 for the bias; identifiable
// when the interval is given, unless `identifiable` says otherwise).
// Errors lead with `where` (file and field path).
Status ReadParameterEstimate(const nlohmann::json& node,
                             const std::string& where, ParameterEstimate* p);

// Logs a fit has not seen, predicted with its estimate (kcrig estimate
// --holdout). Without logs there is none.
struct HoldoutPrediction {
  std::vector<std::string> logs;
  Adequacy adequacy;
};

// `profiles` may be empty (not computed), `holdout` too.
std::string EstimationResultToJson(
    const EstimationResult& result, const std::vector<std::string>& logs,
    const std::vector<ParameterProfile>& profiles,
    const HoldoutPrediction& holdout);

// Intervals widened by less than this are not worth a line.
constexpr double kReportedWidening = 1.1;

// One line when WidenForResidualStructure widened the intervals by more
// than kReportedWidening (how much, and why); "" otherwise.
std::string IntervalWideningSummary(const EstimationResult& result);

// A short human summary: estimates with 95 % intervals (N/mm for
// stiffnesses) and log10 diag((J^T J)^-1) as a text bar chart (paper Fig. 4),
// then the adequacy of the fit to `logs` and of the hold-out's prediction.
// An inadequate model is said in one plain line, with the diagnosis to run.
std::string EstimationSummary(const EstimationResult& result,
                              const std::vector<std::string>& logs,
                              const std::vector<ParameterProfile>& profiles,
                              const HoldoutPrediction& holdout);

// An adequacy assessment as one JSON object (est.json, diag.json,
// campaign.json): verdict, reason, chi-square, dof, p, score, whiteness and
// per channel score and Ljung-Box p.
std::string AdequacyToJson(const Adequacy& adequacy);

// "adequate: chi2/dof ..." or "INADEQUATE: <reason>", one line, no newline.
std::string AdequacyLine(const Adequacy& adequacy);

// The plain warning printed under an inadequate fit to `logs`: the
// intervals assume a correct model, and the diagnosis to run.
std::string InadequacyWarning(const std::vector<std::string>& logs);

// What a designer needs from an est.json: the estimated parameters, their
// values and, when present, the information matrix J^T J of the data.
struct EstimateFile {
  std::vector<std::string> names;
  std::vector<double> values;     // physical units
  Eigen::MatrixXd information;    // empty when the file has none
  Eigen::MatrixXd covariance;     // physical units; empty when none
  double integrator_step = 0;     // [s] the fit's step; 0 when unrecorded
  std::vector<std::string> logs;  // the logs the fit used, as written
  // Per log, where the fit's model started (rig_initial_state); empty when
  // the file has none. A tare's at_start is NaN where the model did not
  // start there (est.json gives it only then).
  std::vector<LogInitialState> initial_states;
};

// Reads and checks an est.json written by kcrig estimate; errors name the
// file and the field.
Status ReadEstimateFile(const std::string& path, EstimateFile* estimate);

}  // namespace kcrig

#endif  // KCRIG_ESTIMATOR_ESTIMATE_IO_H_
