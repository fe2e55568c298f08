// The source tree's config/, loaded once for tests.
#ifndef KCRIG_TESTS_SUPPORT_TEST_CONFIG_H_
#define KCRIG_TESTS_SUPPORT_TEST_CONFIG_H_

#include "gtest/gtest.h"
#include "rt_core/model/excitation.h"
#include "rt_core/model/model_config.h"

namespace kcrig {

inline KcrigConfig SourceConfig() {
  KcrigConfig config;
  const Status status = LoadConfig(KCRIG_TEST_CONFIG_DIR, &config);
  EXPECT_TRUE(status.ok()) << status.message();
  return config;
}

// The paper's initial experiment with the config's defaults.
inline RampExcitation<double> PaperInitialExcitation(
    const ExperimentConfig& experiment) {
  return experiment.Excitation(experiment.phi, experiment.z_a);
}

}  // namespace kcrig

#endif  // KCRIG_TESTS_SUPPORT_TEST_CONFIG_H_
