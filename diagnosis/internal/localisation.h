// Where the nominal model and the logs disagree: the weighted residuals
// sliced by channel, force magnitude and loading direction, their spectrum
// in frequency bands, and their lagged correlation with the force and its
// rate. Fills the localisation part of a DiagnosisResult.
#ifndef KCRIG_DIAGNOSIS_INTERNAL_LOCALISATION_H_
#define KCRIG_DIAGNOSIS_INTERNAL_LOCALISATION_H_

#include <vector>

#include "diagnosis/diagnosis.h"
#include "estimator/experiment.h"

namespace kcrig {

// `residuals[l]`: the weighted residuals (r/sigma) of `logs[l]`.
void Localize(const std::vector<Experiment>& logs,
              const std::vector<std::vector<Vec6<double>>>& residuals,
              const DiagnosisOptions& options, DiagnosisResult* result);

}  // namespace kcrig

#endif  // KCRIG_DIAGNOSIS_INTERNAL_LOCALISATION_H_
