// The force the rig applied, recovered from a noisy load cell and the
// loop's command (estimator/internal/applied_force.h).
#include "estimator/internal/applied_force.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "gtest/gtest.h"

namespace kcrig {
namespace {

// A rig's actuator at 1 kHz: the command, 3 samples' dead time, a first-
// order lag of 6 ms (not the filter's to know); a ramp up, a hold and a
// ramp down on each axis, scaled per axis.
struct Actuator {
  std::vector<Vec3<double>> command, applied;
  explicit Actuator(int n) {
    const double gain = -std::expm1(-1.0 / 6.0);
    Vec3<double> force = Vec3<double>::Zero();
    for (int j = 0; j < n; ++j) {
      const double t = j * 1e-3;
      const double ramp = t < 0.5   ? 0
                          : t < 2.5 ? 2000 * (t - 0.5)
                          : t < 3   ? 4000
                                    : std::max(0.0, 4000 - 8000 * (t - 3));
      command.push_back(Vec3<double>(ramp, -0.5 * ramp, 0.25 * ramp));
      const Vec3<double> delayed =
          j >= 3 ? command[j - 3] : Vec3<double>::Zero();
      force += gain * (delayed - force);
      applied.push_back(force);
    }
  }
};

double RmsError(const std::vector<Vec3<double>>& a,
                const std::vector<Vec3<double>>& b, int axis) {
  double sum = 0;
  for (size_t j = 0; j < a.size(); ++j) {
    sum += (a[j](axis) - b[j](axis)) * (a[j](axis) - b[j](axis));
  }
  return std::sqrt(sum / a.size());
}

TEST(AppliedForceTest, TakesTheLoadCellsNoiseOutAndKeepsTheCorners) {
  const Actuator rig(4000);
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0, 0.5);
  std::vector<Vec3<double>> reading = rig.applied;
  for (Vec3<double>& f : reading) {
    for (int axis = 0; axis < 3; ++axis) f(axis) += noise(rng);
  }
  const std::vector<Vec3<double>> applied =
      AppliedForce(reading, rig.command, 50, 10);
  ASSERT_EQ(applied.size(), reading.size());
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_NEAR(RmsError(reading, rig.applied, axis), 0.5, 0.03);
    // White noise over 21 samples: 0.5 / sqrt(21) = 0.11 N.
    EXPECT_LT(RmsError(applied, rig.applied, axis), 0.15) << axis;
  }
  // At the ramp's corners (t = 0.5, 2.5, 3 s) as well: no smoothing across
  // them bends the force there (the raw reading: 0.5 N).
  for (int axis = 0; axis < 3; ++axis) {
    for (int corner : {500, 2500, 3000}) {
      double sum = 0;
      for (int j = corner - 10; j < corner + 20; ++j) {
        sum += std::pow(applied[j](axis) - rig.applied[j](axis), 2);
      }
      EXPECT_LT(std::sqrt(sum / 30), 0.35) << axis << " " << corner;
    }
  }
}

TEST(AppliedForceTest, ForceTheCommandDoesNotExplainIsKept) {
  // A slow force on top of the actuator's (the rig's reaction, a drift):
  // kept, since the mean passes a smooth signal.
  const Actuator rig(3000);
  std::vector<Vec3<double>> reading = rig.applied;
  for (size_t j = 0; j < reading.size(); ++j) {
    reading[j](1) += 30 * std::sin(2 * std::numbers::pi * 0.5 * j * 1e-3);
  }
  const std::vector<Vec3<double>> applied =
      AppliedForce(reading, rig.command, 50, 10);
  EXPECT_LT(RmsError(applied, reading, 1), 0.1);
}

TEST(AppliedForceTest, AnOffsetAGainAndALogThatStartsUnderLoadAreKept) {
  // The reading 2 % below the command and 5 N off it, and the log starting
  // mid-run at the hold (a CAN capture): the command is not zero before it.
  Actuator rig(4000);
  rig.command.erase(rig.command.begin(), rig.command.begin() + 2600);
  rig.applied.erase(rig.applied.begin(), rig.applied.begin() + 2600);
  std::vector<Vec3<double>> reading = rig.applied;
  for (Vec3<double>& f : reading) f = 0.98 * f + Vec3<double>::Constant(5);
  const std::vector<Vec3<double>> applied =
      AppliedForce(reading, rig.command, 50, 10);
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_LT(RmsError(applied, reading, axis), 0.3) << axis;
    for (int j = 0; j < 20; ++j) {
      EXPECT_NEAR(applied[j](axis), reading[j](axis), 0.5) << j;
    }
  }
}

TEST(AppliedForceTest, AConstantCommandOrAShortLogIsHandled) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> noise(0, 0.5);
  for (double command : {0.0, -3000.0}) {
    std::vector<Vec3<double>> reading(200);
    for (Vec3<double>& f : reading) {
      f = Vec3<double>(command + noise(rng), 2, 3);
    }
    const std::vector<Vec3<double>> commanded(200, Vec3<double>(command, 0, 0));
    const std::vector<Vec3<double>> applied =
        AppliedForce(reading, commanded, 50, 10);
    ASSERT_EQ(applied.size(), 200u);
    for (const Vec3<double>& f : applied) {
      EXPECT_TRUE(f.allFinite());
      EXPECT_NEAR(f(0), command, 0.5) << command;  // 0.11 N RMS
      EXPECT_NEAR(f(2), 3, 1e-9);
    }
  }
  // Shorter than the filter: the mean alone; no log; a command of another
  // length: the reading.
  const std::vector<Vec3<double>> short_log(30, Vec3<double>(1, 2, 3));
  EXPECT_NEAR(AppliedForce(short_log, short_log, 50, 10)[0](1), 2, 1e-12);
  EXPECT_TRUE(AppliedForce({}, {}, 50, 10).empty());
  EXPECT_EQ(AppliedForce(short_log, {}, 50, 10)[0], short_log[0]);
}

}  // namespace
}  // namespace kcrig
