// diag.json (DESIGN.md §4) and the terminal summary of a diagnosis:
// localisation per channel, load regime, frequency band and lag; the drift
// of the stiffnesses between logs; the ranked candidates with their fitted
// parameters and held-out residuals before and after; the verdict.
// SI units in the JSON (with a "unit" beside every quantity that has one),
// mm, deg and N/mm in the summary.
#ifndef KCRIG_DIAGNOSIS_DIAGNOSIS_IO_H_
#define KCRIG_DIAGNOSIS_DIAGNOSIS_IO_H_

#include <string>
#include <vector>

#include "diagnosis/diagnosis.h"

namespace kcrig {

// `design_json`: a discriminating experiment as a JSON object (or "" when
// none was designed).
std::string DiagnosisToJson(const DiagnosisResult& result,
                            const std::vector<std::string>& training_logs,
                            const std::vector<std::string>& holdout_logs,
                            const std::string& design_json);

std::string DiagnosisSummary(const DiagnosisResult& result);

}  // namespace kcrig

#endif  // KCRIG_DIAGNOSIS_DIAGNOSIS_IO_H_
