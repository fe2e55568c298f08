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

// diag.json read back as far as its readers (the report) use it: the
// verdict, confidence, reason and scoring; the load-regime slices (name,
// samples, score per channel); the nominal model and the candidates
// (model, ok, score and gap closed when scored, BIC, fitted values); the
// logs. Fields a hand-written file leaves out stay empty (no nominal model:
// has_nominal false); a null number reads as NaN. A field of the wrong type
// is an error naming the file and the field.
struct DiagnosisFile {
  std::vector<std::string> logs, holdout;
  bool has_nominal = false;
  DiagnosisResult result;
};
Status ReadDiagnosisFile(const std::string& path, DiagnosisFile* file);

}  // namespace kcrig

#endif  // KCRIG_DIAGNOSIS_DIAGNOSIS_IO_H_
