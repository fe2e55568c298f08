// A candidate fit's outcome (its status and EffectFit, every field) as
// bytes and back, exactly: what a fit computed on another MPI rank returns
// (base/batch_runner.h), so that every rank goes on with the same fits.
#ifndef KCRIG_DIAGNOSIS_INTERNAL_FIT_CODEC_H_
#define KCRIG_DIAGNOSIS_INTERNAL_FIT_CODEC_H_

#include <string>
#include <vector>

#include "base/status.h"
#include "estimator/effect_model.h"

namespace kcrig {

std::string EncodeFit(const Status& status, const EffectFit& fit);
// False when `bytes` is not what EncodeFit wrote.
bool DecodeFit(const std::string& bytes, Status* status, EffectFit* fit);

// The same for weighted residuals (one Vec6 per sample).
std::string EncodeResiduals(const Status& status,
                            const std::vector<Vec6<double>>& residuals);
bool DecodeResiduals(const std::string& bytes, Status* status,
                     std::vector<Vec6<double>>* residuals);

}  // namespace kcrig

#endif  // KCRIG_DIAGNOSIS_INTERNAL_FIT_CODEC_H_
