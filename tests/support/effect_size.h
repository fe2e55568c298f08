// The size of an unmodelled effect "in the residual", as the statistical
// tiers define it: the RMS, in noise units, of the nominal model's fitted
// residual on logs of the plant with the effect, simulated without noise
// (validation's NominalFitSigmaHat, which `kcrig validate` uses too).
#ifndef KCRIG_TESTS_SUPPORT_EFFECT_SIZE_H_
#define KCRIG_TESTS_SUPPORT_EFFECT_SIZE_H_

#include <vector>

#include "estimator/experiment.h"
#include "gtest/gtest.h"
#include "rt_core/model/model_config.h"
#include "validation/validation.h"

namespace kcrig {

// sigma_hat of the nominal model (config's, bushings fitted) on the
// noise-free `experiments`.
inline double NominalFitSigmaHat(const KcrigConfig& config,
                                 const std::vector<Experiment>& experiments) {
  double sigma_hat = 0;
  const Status status = NominalFitSigmaHat(config, experiments, &sigma_hat);
  EXPECT_TRUE(status.ok()) << status.message();
  return sigma_hat;
}

}  // namespace kcrig

#endif  // KCRIG_TESTS_SUPPORT_EFFECT_SIZE_H_
