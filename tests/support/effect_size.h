// The size of an unmodelled effect "in the residual", as the statistical
// tiers define it: the RMS, in noise units, of the nominal model's fitted
// residual on logs of the plant with the effect, simulated without noise.
#ifndef KCRIG_TESTS_SUPPORT_EFFECT_SIZE_H_
#define KCRIG_TESTS_SUPPORT_EFFECT_SIZE_H_

#include <vector>

#include "diagnosis/effect_model.h"
#include "estimator/experiment.h"
#include "gtest/gtest.h"
#include "rt_core/model/model_config.h"

namespace kcrig {

// sigma_hat of the nominal model (config's, bushings fitted) on the
// noise-free `experiments`.
inline double NominalFitSigmaHat(const KcrigConfig& config,
                                 const std::vector<Experiment>& experiments) {
  EffectModel nominal;
  EXPECT_TRUE(EffectModel::Create(config.model, {}, 0.1, 10, &nominal).ok());
  EffectFit fit;
  const Status status =
      FitEffectModel(nominal, experiments, {}, EffectFitOptions(),
                     config.experiment.step, &fit);
  EXPECT_TRUE(status.ok()) << status.message();
  return fit.result.sigma_hat;
}

}  // namespace kcrig

#endif  // KCRIG_TESTS_SUPPORT_EFFECT_SIZE_H_
