// Acceptance 4 (foundation issue): static compliances with the signs and
// orders of magnitude a K&C engineer expects, zero response to zero force,
// linearity for small forces, quasi-static response to the default ramp.
#include <cmath>
#include <cstdio>

#include "gtest/gtest.h"
#include "rt_core/model/channels.h"
#include "rt_core/model/simulation.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

Vec6<double> StaticResponse(const SuspensionModel<double>& model,
                            const Vec3<double>& force, double z_a) {
  RigLoad<double> load;
  load.force = force;
  load.point << 0, 0, z_a;
  Vec6<double> y;
  const Status status = SolveStaticEquilibrium(model, load, 50, &y);
  EXPECT_TRUE(status.ok()) << status.message();
  return y;
}

// Compliance per kN, by central difference over +-1 kN: mm/kN and deg/kN.
Vec6<double> CompliancePerKilonewton(const SuspensionModel<double>& model,
                                     const Vec3<double>& direction,
                                     double z_a) {
  const Vec6<double> dy = StaticResponse(model, 1000.0 * direction, z_a) -
                          StaticResponse(model, -1000.0 * direction, z_a);
  Vec6<double> per_kn = dy / 2.0;
  per_kn.head<3>() *= 1e3;      // mm
  per_kn.tail<3>() /= kDegree;  // deg
  return per_kn;
}

void Print(const char* what, const Vec6<double>& c) {
  std::printf(
      "  %-34s x %+.4f  y %+.4f  z %+.4f mm/kN | toe %+.4f  camber %+.4f  "
      "caster %+.4f deg/kN\n",
      what, c(0), c(1), c(2), c(3), c(4), c(5));
}

TEST(PhysicsSanityTest, StaticCompliancesHaveExpectedSignsAndMagnitudes) {
  const KcrigConfig config = SourceConfig();
  const SuspensionModel<double> model(config.model);
  const Vec3<double> lateral(0, 1, 0), longitudinal(1, 0, 0);
  const Vec6<double> lat_wc = CompliancePerKilonewton(model, lateral, 0.0);
  const Vec6<double> lon_wc = CompliancePerKilonewton(model, longitudinal, 0.0);
  const Vec6<double> lat_pad =
      CompliancePerKilonewton(model, lateral, config.experiment.z_a);
  const Vec6<double> lon_pad =
      CompliancePerKilonewton(model, longitudinal, config.experiment.z_a);
  std::printf("static compliance of the configured five-link corner:\n");
  Print("lateral Fy at the wheel centre", lat_wc);
  Print("longitudinal Fx at the wheel centre", lon_wc);
  Print("lateral Fy at z_a = -0.45 m", lat_pad);
  Print("longitudinal Fx at z_a = -0.45 m", lon_pad);

  // A force pushes the wheel centre its own way (positive direct compliance)
  // and the bushings give tenths of a millimetre per kN, not metres or
  // nanometres.
  EXPECT_GT(lat_wc(1), 0.02);
  EXPECT_LT(lat_wc(1), 1.0);
  EXPECT_GT(lon_wc(0), 0.05);
  EXPECT_LT(lon_wc(0), 5.0);
  // Elastic angles of the carrier stay within hundredths to tenths of a
  // degree per kN at the wheel centre.
  for (int k = 3; k < 6; ++k) {
    EXPECT_LT(std::abs(lat_wc(k)), 1.0) << "angle " << k;
    EXPECT_LT(std::abs(lon_wc(k)), 1.0) << "angle " << k;
  }
  // Lateral force below the wheel centre (tyre contact side) tilts the
  // carrier more than the same force at the centre: the moment arm counts.
  EXPECT_GT(std::abs(lat_pad(4)), std::abs(lat_wc(4)));
  // Work done by the rig is positive: F . d > 0 for the generalized
  // displacement, in either direction.
  EXPECT_GT(lat_pad(1), 0.0);
}

TEST(PhysicsSanityTest, ZeroForceGivesZeroDisplacement) {
  const KcrigConfig config = SourceConfig();
  const SuspensionModel<double> model(config.model);
  EXPECT_LT(
      StaticResponse(model, Vec3<double>::Zero(), -0.45).cwiseAbs().maxCoeff(),
      1e-15);
  RampExcitation<double> zero = PaperInitialExcitation(config.experiment);
  zero.fmax = 0.0;
  std::vector<TrajectorySample<double>> samples;
  ASSERT_TRUE(
      SimulateTrajectory(model, zero, SimulationOptions{}, &samples).ok());
  double largest = 0;
  for (const auto& s : samples)
    largest = std::max(largest, s.y.cwiseAbs().maxCoeff());
  EXPECT_LT(largest, 1e-15);
}

// Per-channel sensor sigmas, so metres and radians compare as the estimator
// compares them.
Vec6<double> Sigmas(const ExperimentConfig& experiment) {
  Vec6<double> sigma;
  sigma << Vec3<double>::Constant(experiment.sigma_position),
      Vec3<double>::Constant(experiment.sigma_angle);
  return sigma;
}

// Largest deviation, over channels, of the response to 2 F from twice the
// response to F, relative to that channel's response.
double Nonlinearity(const KcrigConfig& config, double force) {
  const SuspensionModel<double> model(config.model);
  RampExcitation<double> once = PaperInitialExcitation(config.experiment);
  once.fmax = force;
  RampExcitation<double> twice = once;
  twice.fmax = 2 * force;
  std::vector<TrajectorySample<double>> a, b;
  EXPECT_TRUE(SimulateTrajectory(model, once, SimulationOptions{}, &a).ok());
  EXPECT_TRUE(SimulateTrajectory(model, twice, SimulationOptions{}, &b).ok());
  double worst = 0;
  for (int k = 0; k < 6; ++k) {
    double scale = 0, deviation = 0;
    for (size_t j = 0; j < a.size(); ++j) {
      scale = std::max(scale, std::abs(b[j].y(k)));
      deviation = std::max(deviation, std::abs(b[j].y(k) - 2.0 * a[j].y(k)));
    }
    worst = std::max(worst, deviation / scale);
  }
  return worst;
}

TEST(PhysicsSanityTest, ResponseIsLinearInFmaxForSmallForces) {
  const KcrigConfig config = SourceConfig();
  // What remains is geometric (second order in the rotations, e.g. toe
  // times camber in caster), so it must shrink in proportion to the force.
  const double at_1n = Nonlinearity(config, 1.0);
  const double at_10n = Nonlinearity(config, 10.0);
  std::printf("  nonlinearity (2F vs 2 x F): %.2e at 1 N, %.2e at 10 N\n",
              at_1n, at_10n);
  EXPECT_LT(at_1n, 1e-4);
  EXPECT_GT(at_10n / at_1n, 5.0);
  EXPECT_LT(at_10n / at_1n, 20.0);
}

TEST(PhysicsSanityTest, DefaultRampIsQuasiStatic) {
  const KcrigConfig config = SourceConfig();
  const SuspensionModel<double> model(config.model);
  const RampExcitation<double> ramp = PaperInitialExcitation(config.experiment);
  std::vector<TrajectorySample<double>> samples;
  ASSERT_TRUE(
      SimulateTrajectory(model, ramp, SimulationOptions{}, &samples).ok());
  // Gap between the dynamic response and the static equilibrium under the
  // same force, in sensor sigmas, against the largest travel in sigmas. The
  // gap is the suspension damper's lag (time constant d/k = 45 ms), not
  // inertia.
  const Vec6<double> sigma = Sigmas(config.experiment);
  const double travel =
      ((samples.back().y - samples.front().y).cwiseAbs().cwiseQuotient(sigma))
          .maxCoeff();
  double gap = 0;
  for (size_t j = samples.size() / 10; j < samples.size(); j += 100) {
    const Vec6<double> quasi_static =
        StaticResponse(model, samples[j].force, ramp.z_a);
    gap = std::max(gap, (samples[j].y - quasi_static)
                            .cwiseAbs()
                            .cwiseQuotient(sigma)
                            .maxCoeff());
  }
  std::printf(
      "  dynamic gap to the static response: %.2f sigma against a "
      "travel of %.0f sigma (%.2f %%)\n",
      gap, travel, 100 * gap / travel);
  EXPECT_LT(gap / travel, 0.01);
}

}  // namespace
}  // namespace kcrig
