// est.json (DESIGN.md §4): per parameter value, standard error and 95 %
// interval; covariance, correlation, log10 diag((J^T J)^-1), singular values
// of J; residual RMS per channel; cost, iterations, seconds, convergence.
// Quantities that do not exist (a non-identifiable parameter's standard
// error) are written as null, never as huge numbers.
#ifndef KCRIG_ESTIMATOR_ESTIMATE_IO_H_
#define KCRIG_ESTIMATOR_ESTIMATE_IO_H_

#include <string>
#include <vector>

#include "estimator/estimator.h"
#include "estimator/profile_likelihood.h"

namespace kcrig {

// Stiffnesses read best in N/mm, everything else in its SI unit: the factor
// from SI to the displayed unit, and that unit.
double DisplayScale(const ParameterEstimate& p);
std::string DisplayUnit(const ParameterEstimate& p);

// `profiles` may be empty (not computed).
std::string EstimationResultToJson(
    const EstimationResult& result, const std::vector<std::string>& logs,
    const std::vector<ParameterProfile>& profiles);

// A short human summary: estimates with 95 % intervals (N/mm for
// stiffnesses) and log10 diag((J^T J)^-1) as a text bar chart (paper Fig. 4).
std::string EstimationSummary(const EstimationResult& result,
                              const std::vector<ParameterProfile>& profiles);

// What a designer needs from an est.json: the estimated parameters, their
// values and, when present, the information matrix J^T J of the data.
struct EstimateFile {
  std::vector<std::string> names;
  std::vector<double> values;   // physical units
  Eigen::MatrixXd information;  // empty when the file has none
};

// Reads and checks an est.json written by kcrig estimate; errors name the
// file and the field.
Status ReadEstimateFile(const std::string& path, EstimateFile* estimate);

}  // namespace kcrig

#endif  // KCRIG_ESTIMATOR_ESTIMATE_IO_H_
