#include "rt_core/model/suspension_model.h"

#include <random>

#include "Eigen/Eigenvalues"
#include "ceres/jet.h"
#include "gtest/gtest.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

using Jet12 = ceres::Jet<double, 12>;

// The analytic dQ/dy and dQ/dz against forward-mode automatic
// differentiation of Q itself, at random states away from the design
// position (so every term, including damping and gyroscopic ones, counts).
TEST(SuspensionModelTest, AnalyticJacobiansMatchAutomaticDifferentiation) {
  const KcrigConfig config = SourceConfig();
  const SuspensionModel<double> model(config.model);
  const SuspensionModel<Jet12> jet_model(config.model.Cast<Jet12>());
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    Vec6<double> y, z;
    for (int k = 0; k < 3; ++k) {
      y(k) = 5e-3 * unit(rng);      // m
      y(k + 3) = 0.05 * unit(rng);  // rad
      z(k) = 0.2 * unit(rng);       // m/s
      z(k + 3) = 3.0 * unit(rng);   // rad/s
    }
    RigLoad<double> load;
    load.force << 3000 * unit(rng), 3000 * unit(rng), 500 * unit(rng);
    load.point << 0, 0, -0.45;

    GeneralizedForce<double> analytic;
    model.Evaluate(load, y, z, true, &analytic);

    Vec6<Jet12> y_jet, z_jet;
    for (int k = 0; k < 6; ++k) {
      y_jet(k) = Jet12(y(k), k);
      z_jet(k) = Jet12(z(k), 6 + k);
    }
    RigLoad<Jet12> load_jet{load.force.cast<Jet12>(), load.point.cast<Jet12>()};
    GeneralizedForce<Jet12> automatic;
    jet_model.Evaluate(load_jet, y_jet, z_jet, false, &automatic);

    for (int i = 0; i < 6; ++i) {
      EXPECT_NEAR(automatic.q(i).a, analytic.q(i), 1e-9 * analytic.q.norm());
      const double scale_y = analytic.dq_dy.row(i).norm() + 1.0;
      const double scale_z = analytic.dq_dz.row(i).norm() + 1.0;
      for (int k = 0; k < 6; ++k) {
        EXPECT_NEAR(automatic.q(i).v(k), analytic.dq_dy(i, k), 1e-10 * scale_y)
            << "dQ" << i << "/dy" << k << " trial " << trial;
        EXPECT_NEAR(automatic.q(i).v(6 + k), analytic.dq_dz(i, k),
                    1e-10 * scale_z)
            << "dQ" << i << "/dz" << k << " trial " << trial;
      }
    }
  }
}

TEST(SuspensionModelTest, DesignPositionIsUnloadedEquilibrium) {
  const KcrigConfig config = SourceConfig();
  const SuspensionModel<double> model(config.model);
  GeneralizedForce<double> g;
  model.Evaluate(RigLoad<double>{}, Vec6<double>::Zero(), Vec6<double>::Zero(),
                 true, &g);
  EXPECT_LT(g.q.norm(), 1e-12);
  // Stiff in all six directions: in (displacement, rotation vector)
  // coordinates -dQ/dq is symmetric positive definite at the unloaded design
  // position. dQ/dy holds Cardan columns, dQ/dq = dQ/dy G^-1.
  Mat6<double> to_rotation_vector = Mat6<double>::Identity();
  to_rotation_vector.bottomRightCorner<3, 3>() =
      InverseAngularRateMatrix<double>(Vec3<double>::Zero());
  const Mat6<double> stiffness = -g.dq_dy * to_rotation_vector;
  EXPECT_LT((stiffness - stiffness.transpose()).norm(),
            1e-9 * stiffness.norm());
  const Eigen::SelfAdjointEigenSolver<Mat6<double>> eigen(
      0.5 * (stiffness + stiffness.transpose()));
  EXPECT_GT(eigen.eigenvalues().minCoeff(), 0.0);
}

TEST(RotationTest, CardanRotationIsRzRxRy) {
  const Vec3<double> angles(0.1, -0.2, 0.3);
  const Mat3<double> expected =
      (Eigen::AngleAxisd(angles(0), Eigen::Vector3d::UnitZ()) *
       Eigen::AngleAxisd(angles(1), Eigen::Vector3d::UnitX()) *
       Eigen::AngleAxisd(angles(2), Eigen::Vector3d::UnitY()))
          .toRotationMatrix();
  EXPECT_LT((CardanRotation(angles) - expected).norm(), 1e-15);
}

TEST(RotationTest, AngularRateMatrixAndInverse) {
  const Vec3<double> angles(0.1, -0.2, 0.3);
  EXPECT_LT((AngularRateMatrix(angles) * InverseAngularRateMatrix(angles) -
             Mat3<double>::Identity())
                .norm(),
            1e-14);
  // Column k of G is R^T dR/d(angle_k), checked by central differences.
  const Mat3<double> r = CardanRotation(angles);
  for (int k = 0; k < 3; ++k) {
    Vec3<double> step = Vec3<double>::Zero();
    step(k) = 1e-6;
    const Mat3<double> dr = (CardanRotation<double>(angles + step) -
                             CardanRotation<double>(angles - step)) /
                            2e-6;
    const Mat3<double> omega_hat = r.transpose() * dr;
    const Vec3<double> g_column = AngularRateMatrix(angles).col(k);
    EXPECT_NEAR(omega_hat(2, 1), g_column(0), 1e-9);
    EXPECT_NEAR(omega_hat(0, 2), g_column(1), 1e-9);
    EXPECT_NEAR(omega_hat(1, 0), g_column(2), 1e-9);
  }
}

}  // namespace
}  // namespace kcrig
