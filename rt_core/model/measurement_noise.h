// Additive Gaussian sensor noise on the six measured channels, with the
// config's sigmas: sigma_position on x, y, z and sigma_angle on the angles.
#ifndef KCRIG_RT_CORE_MODEL_MEASUREMENT_NOISE_H_
#define KCRIG_RT_CORE_MODEL_MEASUREMENT_NOISE_H_

#include <cstdint>
#include <random>

#include "rt_core/model/rotation.h"

namespace kcrig {

class MeasurementNoise {
 public:
  MeasurementNoise(double sigma_position, double sigma_angle,
                   std::uint64_t seed)
      : rng_(seed) {
    sigma_ << sigma_position, sigma_position, sigma_position, sigma_angle,
        sigma_angle, sigma_angle;
  }

  void Apply(Vec6<double>* y) {
    for (int k = 0; k < 6; ++k) (*y)(k) += sigma_(k) * normal_(rng_);
  }

 private:
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
  Vec6<double> sigma_;
};

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_MODEL_MEASUREMENT_NOISE_H_
