// The model's analytic static compliance (from dQ/dy) against central
// differences of its static equilibrium (Newton on Q(y, 0) = 0), for forces
// at the wheel centre, at the contact patch and at lever points that make
// moments.
#include "rt_core/model/static_compliance.h"

#include <cmath>
#include <cstdio>

#include "gtest/gtest.h"
#include "rt_core/model/rotation.h"
#include "rt_core/model/simulation.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

constexpr double kPatchZ = -0.307;

Vec6<double> Equilibrium(const SuspensionModel<double>& model,
                         const Vec3<double>& force, const Vec3<double>& point) {
  RigLoad<double> load;
  load.force = force;
  load.point = point;
  Vec6<double> y;
  EXPECT_TRUE(SolveStaticEquilibrium(model, load, 50, &y).ok());
  return y;
}

// d(pose)/d(force component k) at carrier point `point`, by central
// differences over +-h: second order, and the equilibrium is solved to
// machine precision.
Vec6<double> DifferenceColumn(const SuspensionModel<double>& model, int k,
                              const Vec3<double>& point) {
  const double h = 10.0;  // [N]
  const Vec3<double> f = h * Vec3<double>::Unit(k);
  return (Equilibrium(model, f, point) - Equilibrium(model, -f, point)) /
         (2 * h);
}

class StaticComplianceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(
        ComputeStaticCompliance(parameters_, kPatchZ, &compliance_).ok());
  }
  const SuspensionParameters<double> parameters_ = SourceConfig().model;
  const SuspensionModel<double> model_{parameters_};
  StaticCompliance compliance_;
};

// Relative to the column's largest entry: the entries span orders of
// magnitude (mm/kN beside deg/kN).
void ExpectColumnNear(const Vec6<double>& analytic,
                      const Vec6<double>& difference, const char* what) {
  const double scale = difference.cwiseAbs().maxCoeff();
  ASSERT_GT(scale, 0) << what;
  const double relative = (analytic - difference).cwiseAbs().maxCoeff() / scale;
  std::printf("  %s: largest difference %.2g of the column's largest entry\n",
              what, relative);
  EXPECT_LT(relative, 1e-6) << what << "\nanalytic   " << analytic.transpose()
                            << "\ndifference " << difference.transpose();
}

TEST_F(StaticComplianceTest, ForceColumnsEqualDifferencesOfTheEquilibrium) {
  const Vec3<double> centre = Vec3<double>::Zero();
  for (int k = 0; k < 3; ++k) {
    ExpectColumnNear(compliance_.wheel_centre.col(k),
                     DifferenceColumn(model_, k, centre), "wheel centre");
  }
}

TEST_F(StaticComplianceTest, MomentColumnsEqualDifferencesOfLeverForces) {
  // A force F at carrier point p is F at the centre plus the moment
  // R (p x R^T F): the moment column is the lever force's column minus the
  // centre's, per unit moment.
  const double lever = 0.5;  // [m]
  const Mat3<double> rotation =
      CardanRotation<double>(Vec3<double>(compliance_.rest.tail<3>()));
  struct Case {
    int force;
    Vec3<double> point;
  };
  const Case cases[] = {{1, Vec3<double>(0, 0, lever)},   // Fy at +z: -Mx
                        {0, Vec3<double>(0, 0, lever)},   // Fx at +z: +My
                        {0, Vec3<double>(0, lever, 0)}};  // Fx at +y: -Mz
  for (const Case& c : cases) {
    const Vec3<double> force = Vec3<double>::Unit(c.force);
    const Vec3<double> moment =
        rotation * c.point.cross(rotation.transpose() * force);
    const Vec6<double> moment_response =
        DifferenceColumn(model_, c.force, c.point) -
        DifferenceColumn(model_, c.force, Vec3<double>::Zero());
    const Vec6<double> analytic =
        compliance_.wheel_centre.rightCols<3>() * moment;
    ExpectColumnNear(analytic, moment_response, "moment");
  }
}

TEST_F(StaticComplianceTest, ContactPatchColumnsEqualDifferences) {
  // Forces at the contact patch; rows the patch point's displacement:
  // r + R p, differenced from the equilibria.
  const Vec3<double> patch(0, 0, kPatchZ);
  const double h = 10.0;
  for (int k = 0; k < 3; ++k) {
    const Vec3<double> f = h * Vec3<double>::Unit(k);
    Vec6<double> plus = Equilibrium(model_, f, patch);
    Vec6<double> minus = Equilibrium(model_, -f, patch);
    auto patch_pose = [&](const Vec6<double>& y) {
      Vec6<double> pose = y;
      pose.head<3>() +=
          CardanRotation<double>(Vec3<double>(y.tail<3>())) * patch;
      return pose;
    };
    const Vec6<double> difference =
        (patch_pose(plus) - patch_pose(minus)) / (2 * h);
    ExpectColumnNear(compliance_.contact_patch.col(k), difference,
                     "contact patch");
  }
}

TEST_F(StaticComplianceTest, StaticGradientIsTheForceAtItsHeight) {
  const double phi = 0.6, z_a = -0.45;
  const Vec3<double> direction(std::cos(phi), std::sin(phi), 0);
  const Vec3<double> point(0, 0, z_a);
  Vec6<double> difference = Vec6<double>::Zero();
  for (int k = 0; k < 2; ++k) {
    difference += direction(k) * DifferenceColumn(model_, k, point);
  }
  ExpectColumnNear(StaticGradient(compliance_, direction, z_a), difference,
                   "gradient");
}

}  // namespace
}  // namespace kcrig
