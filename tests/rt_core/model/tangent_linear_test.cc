// Issue #18: the tangent-linear step gives the Jet reference's sensitivities
// (both are the exact derivatives of the discrete semi-implicit Euler) to
// 1e-10 relative, for every kind of parameter the estimator accepts and for
// tangents of the load, over whole trajectories at random parameters and
// designs, and for single steps from random states with random tangents.
#include "rt_core/model/tangent_linear.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "ceres/jet.h"
#include "estimator/internal/sensitivity_plant.h"
#include "gtest/gtest.h"
#include "rt_core/model/rig_plant.h"
#include "rt_core/model/simulation.h"
#include "tests/support/dual.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

constexpr int kDirections = 8;
using Jet8 = ceres::Jet<double, kDirections>;

// The parameters with direction k = the relative change of `names[k]`.
SuspensionParameters<Jet8> Seeded(const SuspensionParameters<double>& nominal,
                                  const std::vector<std::string>& names) {
  SuspensionParameters<Jet8> p = nominal.Cast<Jet8>();
  for (size_t k = 0; k < names.size(); ++k) {
    Jet8* value = FindParameter(&p, names[k]);
    EXPECT_NE(value, nullptr) << names[k];
    if (value == nullptr) continue;
    // A hard point at 0 still gets a unit tangent (1 mm).
    const double scale = value->a != 0 ? value->a : 1e-3;
    value->v[static_cast<int>(k)] = scale;
  }
  return p;
}

// Worst relative difference of the tangents of two trajectories, per
// (channel, direction) relative to that tangent's largest magnitude.
double WorstRelativeDifference(const std::vector<TrajectorySample<Jet8>>& a,
                               const std::vector<TrajectorySample<Jet8>>& b,
                               int directions) {
  EXPECT_EQ(a.size(), b.size());
  double worst = 0;
  for (int k = 0; k < 6; ++k) {
    for (int d = 0; d < directions; ++d) {
      double scale = 0, difference = 0;
      for (size_t j = 0; j < a.size(); ++j) {
        scale = std::max(scale, std::abs(a[j].y(k).v[d]));
        difference =
            std::max(difference, std::abs(a[j].y(k).v[d] - b[j].y(k).v[d]));
      }
      if (scale > 0) worst = std::max(worst, difference / scale);
      EXPECT_GT(scale, 0.0) << "channel " << k << " direction " << d;
    }
  }
  return worst;
}

// The tangent-linear trajectory against the Jet reference: the values to
// rounding, and the worst relative difference of the tangents.
double TrajectoryDifference(const SuspensionParameters<Jet8>& p,
                            const RampExcitation<Jet8>& excitation,
                            const SimulationOptions& options, int directions) {
  std::vector<TrajectorySample<Jet8>> reference, tangent_linear;
  EXPECT_TRUE(SimulateTrajectory(SuspensionModel<Jet8>(p), excitation, options,
                                 &reference)
                  .ok());
  EXPECT_TRUE(SimulateTrajectory(TangentLinearModel<Jet8>(p), excitation,
                                 options, &tangent_linear)
                  .ok());
  for (size_t j = 0; j < reference.size() && j < tangent_linear.size(); ++j) {
    for (int k = 0; k < 6; ++k) {
      EXPECT_NEAR(tangent_linear[j].y(k).a, reference[j].y(k).a,
                  1e-12 * (1 + std::abs(reference[j].y(k).a)));
    }
  }
  return WorstRelativeDifference(reference, tangent_linear, directions);
}

SuspensionParameters<double> Perturbed(SuspensionParameters<double> p,
                                       std::mt19937* random) {
  std::uniform_real_distribution<double> factor(0.7, 1.4);
  for (AxialElement<double>& e : p.bushings) {
    e.stiffness *= factor(*random);
    e.damping *= factor(*random);
  }
  p.spring.stiffness *= factor(*random);
  p.mass *= factor(*random);
  return p;
}

void ExpectTrajectoriesAgree(const std::vector<std::string>& names,
                             bool load_tangent, unsigned seed) {
  const KcrigConfig config = SourceConfig();
  std::mt19937 random(seed);
  const SuspensionParameters<double> nominal = Perturbed(config.model, &random);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  std::uniform_real_distribution<double> height(-0.1, 0.3);
  std::uniform_real_distribution<double> amplitude(1000, 5000);
  RampExcitation<double> design = PaperInitialExcitation(config.experiment);
  design.phi = angle(random);
  design.z_a = height(random);
  design.fmax = amplitude(random);
  design.duration = 1.0;
  design.hold = 0.2;
  design.return_duration = 0.5;

  const SuspensionParameters<Jet8> p = Seeded(nominal, names);
  RampExcitation<Jet8> excitation = design.Cast<Jet8>();
  int directions = static_cast<int>(names.size());
  if (load_tangent) {
    excitation.fmax.v[directions++] = design.fmax;
    excitation.phi.v[directions++] = 1.0;
    excitation.z_a.v[directions++] = 0.1;  // the acting point
  }
  SimulationOptions options;
  options.steps_per_sample = 2;
  const double worst = TrajectoryDifference(p, excitation, options, directions);
  std::printf("seed %u: worst relative difference %.3g\n", seed, worst);
  EXPECT_LE(worst, 1e-10);
}

TEST(TangentLinearTest, StiffnessDampingSpringAndMassesMatchTheJets) {
  for (unsigned seed : {1u, 2u, 3u}) {
    ExpectTrajectoriesAgree(
        {"c_O1", "c_P", "d_V1", "k_spring", "d_damper", "mass", "Jyy", "Jzz"},
        /*load_tangent=*/false, seed);
  }
}

// The load's tangents (amplitude, direction, acting point) with linear
// parameters only.
TEST(TangentLinearTest, TheLoadAndLinearParametersMatchTheJets) {
  for (unsigned seed : {10u, 11u}) {
    ExpectTrajectoriesAgree({"c_O1", "d_V1", "k_spring", "mass", "Jxx"},
                            /*load_tangent=*/true, seed);
  }
}

TEST(TangentLinearTest, HardPointsAndTheLoadMatchTheJets) {
  for (unsigned seed : {4u, 5u, 6u}) {
    ExpectTrajectoriesAgree(
        {"O1.x", "N2.y", "U1.z", "spring_chassis.z", "spring_carrier.y"},
        /*load_tangent=*/true, seed);
  }
}

// Tangents far below Eigen's isZero threshold (1e-12) are tangents: a
// 1e-13 m hard-point tangent times a bushing rate of 4e6 N/m moves the
// wheel. The products must not skip them.
TEST(TangentLinearTest, TinyHardPointAndLoadTangentsAreNotDropped) {
  const KcrigConfig config = SourceConfig();
  SuspensionParameters<Jet8> p = Seeded(config.model, {"c_O1"});
  FindParameter(&p, "O1.x")->v[1] = 1e-13;
  RampExcitation<Jet8> excitation =
      PaperInitialExcitation(config.experiment).Cast<Jet8>();
  excitation.duration = 0.5;
  excitation.z_a.v[2] = 1e-14;
  const double worst =
      TrajectoryDifference(p, excitation, SimulationOptions(), 3);
  std::printf("tiny tangents: worst relative difference %.3g\n", worst);
  EXPECT_LE(worst, 1e-10);
}

// Single steps from random states with random state tangents; with
// `load_tangent` the load's force and acting point carry a direction each.
void ExpectStepsAgree(const std::vector<std::string>& names, bool load_tangent,
                      unsigned seed) {
  const KcrigConfig config = SourceConfig();
  std::mt19937 random(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const SuspensionParameters<Jet8> p =
        Seeded(Perturbed(config.model, &random), names);
    ModelState<Jet8> state;
    for (int k = 0; k < 6; ++k) {
      const double pose_scale = k < 3 ? 0.01 : 0.02;  // m, rad
      const double rate_scale = k < 3 ? 0.2 : 0.5;    // m/s, rad/s
      state.y(k).a = pose_scale * normal(random);
      state.z(k).a = rate_scale * normal(random);
      for (int d = 0; d < kDirections; ++d) {
        state.y(k).v[d] = 1e-3 * normal(random);
        state.z(k).v[d] = 1e-2 * normal(random);
      }
    }
    RigLoad<Jet8> load;
    for (int k = 0; k < 3; ++k) {
      load.force(k) = Jet8(2000 * normal(random));
      if (load_tangent) {
        load.force(k).v[trial % kDirections] = 100 * normal(random);
      }
    }
    load.point(2) = Jet8(0.1 * normal(random));
    if (load_tangent) {
      for (int k = 0; k < 3; ++k) {
        load.point(k).v[(trial + 3 + k) % kDirections] = 0.01 * normal(random);
      }
    }

    ModelState<Jet8> reference = state, tangent_linear = state;
    SemiImplicitEulerStep(SuspensionModel<Jet8>(p), load, 1e-3, &reference);
    SemiImplicitEulerStep(TangentLinearModel<Jet8>(p), load, 1e-3,
                          &tangent_linear);
    for (int k = 0; k < 6; ++k) {
      for (const auto& [a, b] :
           {std::pair{reference.y(k), tangent_linear.y(k)},
            std::pair{reference.z(k), tangent_linear.z(k)}}) {
        const double scale = std::max(a.v.cwiseAbs().maxCoeff(), 1e-300);
        EXPECT_LE((a.v - b.v).cwiseAbs().maxCoeff() / scale, 1e-10)
            << "trial " << trial << " component " << k;
        // The same step in other rounding (Jet LU against double LU).
        EXPECT_NEAR(a.a, b.a, 1e-12 * (1 + std::abs(a.a)));
      }
    }
  }
}

// Only parameters Q and M are linear in.
TEST(TangentLinearTest, OneStepWithLinearParametersMatchesTheJets) {
  ExpectStepsAgree(
      {"c_O2", "d_O2", "c_V1", "k_spring", "d_damper", "Jzz", "mass", "Jxx"},
      /*load_tangent=*/false, 7);
}

// The load's tangents with linear parameters.
TEST(TangentLinearTest, OneStepWithLinearParametersAndLoadMatchesTheJets) {
  ExpectStepsAgree(
      {"c_O2", "d_O2", "c_V1", "k_spring", "d_damper", "Jzz", "mass", "Jxx"},
      /*load_tangent=*/true, 9);
}

// Hard points and a load tangent.
TEST(TangentLinearTest, OneStepWithHardPointsAndLoadMatchesTheJets) {
  ExpectStepsAgree(
      {"c_O2", "d_O2", "V2.x", "U2.y", "Jzz", "mass", "c_V1", "P.z"},
      /*load_tangent=*/true, 8);
}

// Largest |a - b| relative to the largest |a|, over a matrix.
template <typename A, typename B>
double RelativeDifference(const A& a, const B& b) {
  return (a - b).cwiseAbs().maxCoeff() /
         std::max(a.cwiseAbs().maxCoeff(), 1e-300);
}

// The closed-form derivatives of Q's Jacobians along w against Evaluate in
// dual numbers (the reference), at random states, directions, loads and
// effect hooks, with every element of every Jacobian compared.
TEST(TangentLinearTest, ClosedFormJacobianDerivativesMatchDualNumbers) {
  using D = Dual<double>;
  std::mt19937 random(11);
  std::normal_distribution<double> normal;
  const SuspensionParameters<double> nominal = SourceConfig().model;
  for (int trial = 0; trial < 20; ++trial) {
    SuspensionModel<double> model(Perturbed(nominal, &random));
    SuspensionModel<D> dual_model(model.parameters().Cast<D>());
    typename SuspensionModel<double>::StiffeningCoefficients stiffening;
    typename SuspensionModel<D>::StiffeningCoefficients dual_stiffening;
    typename SuspensionModel<double>::ExtraBushingForce extra;
    typename SuspensionModel<D>::ExtraBushingForce dual_extra;
    for (int i = 0; i < kNumBushings; ++i) {
      for (int t = 0; t < kStiffeningTerms; ++t) {
        stiffening[t][i] = (trial % 2) * 1e9 * normal(random);
        dual_stiffening[t][i] = stiffening[t][i];
      }
      extra.force[i] = 100 * normal(random);
      extra.stiffness[i] = 1e5 * std::abs(normal(random));
      extra.reference[i] = 1e-3 * normal(random);
      dual_extra.force[i] = extra.force[i];
      dual_extra.stiffness[i] = extra.stiffness[i];
      dual_extra.reference[i] = extra.reference[i];
    }
    model.SetProgressiveStiffness(stiffening);
    dual_model.SetProgressiveStiffness(dual_stiffening);
    model.SetExtraBushingForce(extra);
    dual_model.SetExtraBushingForce(dual_extra);

    Vec6<double> y, z, w_y, w_z;
    Vec6<D> y_dual, z_dual;
    for (int k = 0; k < 6; ++k) {
      y(k) = (k < 3 ? 0.01 : 0.05) * normal(random);
      z(k) = (k < 3 ? 0.2 : 0.5) * normal(random);
      w_y(k) = 1e-4 * normal(random);
      w_z(k) = 1e-2 * normal(random);
      y_dual(k) = D(y(k), w_y(k));
      z_dual(k) = D(z(k), w_z(k));
    }
    RigLoad<double> load;
    RigLoad<D> dual_load;
    for (int k = 0; k < 3; ++k) {
      load.force(k) = 2000 * normal(random);
      load.point(k) = 0.1 * normal(random);
      dual_load.force(k) = load.force(k);
      dual_load.point(k) = load.point(k);
    }

    GeneralizedForce<double> g;
    typename SuspensionModel<double>::PointState point;
    model.Evaluate(load, y, z, true, &g, nullptr, nullptr, &point);
    typename SuspensionModel<double>::JacobianDerivatives closed_form;
    typename SuspensionModel<double>::DerivativeRequest request;
    request.hooks = true;
    model.DifferentiateJacobians(point, w_y, w_z, request, &closed_form);
    GeneralizedForce<D> g_dual;
    typename SuspensionModel<D>::LinearParameterJacobian p_dual;
    typename SuspensionModel<D>::HookAndLoadJacobian hook_dual;
    dual_model.Evaluate(dual_load, y_dual, z_dual, true, &g_dual, &p_dual,
                        &hook_dual);
    auto e = [](const auto& m) {
      return m.unaryExpr([](const D& x) { return x.e; }).eval();
    };
    const auto& p = closed_form.parameters;
    const auto& h = closed_form.hooks;
    const std::vector<std::pair<std::string, double>> differences = {
        {"dq_dy", RelativeDifference(e(g_dual.dq_dy), closed_form.dq_dy)},
        {"dq_dz", RelativeDifference(e(g_dual.dq_dz), closed_form.dq_dz)},
        {"stiffness", RelativeDifference(e(p_dual.stiffness), p.stiffness)},
        {"damping", RelativeDifference(e(p_dual.damping), p.damping)},
        {"inertia", RelativeDifference(e(p_dual.inertia), p.inertia)},
        {"stiffening 0",
         RelativeDifference(e(hook_dual.stiffening[0]), h.stiffening[0])},
        {"stiffening 1",
         RelativeDifference(e(hook_dual.stiffening[1]), h.stiffening[1])},
        {"stiffening 2",
         RelativeDifference(e(hook_dual.stiffening[2]), h.stiffening[2])},
        {"extra force",
         RelativeDifference(e(hook_dual.extra_force), h.extra_force)},
        {"extra stiffness",
         RelativeDifference(e(hook_dual.extra_stiffness), h.extra_stiffness)},
        {"extra reference",
         RelativeDifference(e(hook_dual.extra_reference), h.extra_reference)},
        {"load force",
         RelativeDifference(e(hook_dual.load_force), h.load_force)},
        {"load point",
         RelativeDifference(e(hook_dual.load_point), h.load_point)}};
    for (const auto& [name, difference] : differences) {
      EXPECT_LE(difference, 1e-12) << name << ", trial " << trial;
    }
  }
}

// The hard-point Jacobians and their derivatives along w in closed form
// against Evaluate in nested dual numbers: the inner direction a hard-point
// coordinate, the outer one w, so Q's inner parts are the Jacobian's column
// and its mixed parts the derivative's. Random states, directions, loads,
// stiffening and extra forces; every element and coordinate.
TEST(TangentLinearTest, ClosedFormHardPointJacobiansMatchDualNumbers) {
  using D = Dual<double>;
  using DD = Dual<D>;
  constexpr int kElements = SuspensionModel<double>::kNumElements;
  std::mt19937 random(12);
  std::normal_distribution<double> normal;
  const SuspensionParameters<double> nominal = SourceConfig().model;
  for (int trial = 0; trial < 10; ++trial) {
    const SuspensionParameters<double> parameters = Perturbed(nominal, &random);
    SuspensionModel<double> model(parameters);
    typename SuspensionModel<double>::StiffeningCoefficients stiffening;
    typename SuspensionModel<double>::ExtraBushingForce extra;
    for (int i = 0; i < kNumBushings; ++i) {
      for (int t = 0; t < kStiffeningTerms; ++t) {
        stiffening[t][i] = (trial % 2) * 1e9 * normal(random);
      }
      extra.force[i] = 100 * normal(random);
      extra.stiffness[i] = 1e5 * std::abs(normal(random));
      extra.reference[i] = 1e-3 * normal(random);
    }
    model.SetProgressiveStiffness(stiffening);
    model.SetExtraBushingForce(extra);
    Vec6<double> y, z, w_y, w_z;
    for (int k = 0; k < 6; ++k) {
      y(k) = (k < 3 ? 0.01 : 0.05) * normal(random);
      z(k) = (k < 3 ? 0.2 : 0.5) * normal(random);
      w_y(k) = 1e-4 * normal(random);
      w_z(k) = 1e-2 * normal(random);
    }
    RigLoad<double> load;
    for (int k = 0; k < 3; ++k) {
      load.force(k) = 2000 * normal(random);
      load.point(k) = 0.1 * normal(random);
    }
    GeneralizedForce<double> g;
    typename SuspensionModel<double>::PointState point;
    model.Evaluate(load, y, z, true, &g, nullptr, nullptr, &point);
    typename SuspensionModel<double>::DerivativeRequest request;
    request.hard_points.fill(true);
    typename SuspensionModel<double>::JacobianDerivatives closed_form;
    model.DifferentiateJacobians(point, w_y, w_z, request, &closed_form);

    // The dual-dual model and inputs, the coordinate seeded per column.
    typename SuspensionModel<DD>::StiffeningCoefficients dd_stiffening;
    typename SuspensionModel<DD>::ExtraBushingForce dd_extra;
    for (int i = 0; i < kNumBushings; ++i) {
      for (int t = 0; t < kStiffeningTerms; ++t) {
        dd_stiffening[t][i] = stiffening[t][i];
      }
      dd_extra.force[i] = extra.force[i];
      dd_extra.stiffness[i] = extra.stiffness[i];
      dd_extra.reference[i] = extra.reference[i];
    }
    Vec6<DD> y_dd, z_dd;
    for (int k = 0; k < 6; ++k) {
      y_dd(k) = DD(D(y(k)), D(w_y(k)));
      z_dd(k) = DD(D(z(k)), D(w_z(k)));
    }
    RigLoad<DD> load_dd;
    for (int k = 0; k < 3; ++k) {
      load_dd.force(k) = load.force(k);
      load_dd.point(k) = load.point(k);
    }
    for (int i = 0; i < kElements; ++i) {
      Mat6<double> value, derivative;
      for (int c = 0; c < 6; ++c) {
        SuspensionParameters<DD> seeded = parameters.Cast<DD>();
        AxialElement<DD>& e =
            i < kNumBushings ? seeded.bushings[i] : seeded.spring;
        DD& coordinate = c < 3 ? e.chassis_point(c) : e.carrier_point(c - 3);
        coordinate.a.e = 1.0;
        SuspensionModel<DD> dd_model(seeded);
        dd_model.SetProgressiveStiffness(dd_stiffening);
        dd_model.SetExtraBushingForce(dd_extra);
        GeneralizedForce<DD> g_dd;
        dd_model.Evaluate(load_dd, y_dd, z_dd, false, &g_dd);
        for (int r = 0; r < 6; ++r) {
          value(r, c) = g_dd.q(r).a.e;
          derivative(r, c) = g_dd.q(r).e.e;
        }
      }
      EXPECT_LE(RelativeDifference(value, model.HardPointJacobianOf(point, i)),
                1e-12)
          << "element " << i << ", trial " << trial;
      EXPECT_LE(RelativeDifference(derivative, closed_form.hard_points[i]),
                1e-12)
          << "element " << i << ", trial " << trial;
    }
  }
}

// Enables `effect`; c_O1, with `seed_effect` the effect's parameters, and
// the named hard-point coordinates carry the directions (their number is
// returned).
int SeedEffect(const std::string& effect, bool seed_effect,
               const BushingSet& at,
               const std::vector<std::string>& hard_points,
               BasicPlantEffects<Jet8>* e, SuspensionParameters<Jet8>* p) {
  int d = 0;
  auto seed_always = [&d](Jet8* x) { x->v[d++] = x->a != 0 ? x->a : 1e-3; };
  auto seed = [&](Jet8* x) {
    if (seed_effect) seed_always(x);
  };
  seed_always(&p->bushings[kO1].stiffness);
  if (effect == "bushing_damping") {
    e->bushing_damping.enabled = true;
    seed(&e->bushing_damping.d);
  } else if (effect == "hysteresis") {
    e->hysteresis.enabled = true;
    seed(&e->hysteresis.force);
    seed(&e->hysteresis.sigma);
  } else if (effect == "progressive_stiffness") {
    e->progressive_stiffness.enabled = true;
    // Symmetric and asymmetric terms, within the deflections of the ramp.
    e->progressive_stiffness.c2 = Jet8(2e8);
    e->progressive_stiffness.a2 = Jet8(-3e8);
    seed(&e->progressive_stiffness.c3);
    seed(&e->progressive_stiffness.c2);
    seed(&e->progressive_stiffness.a2);
  } else if (effect == "actuator_lag") {
    e->actuator_lag.enabled = true;
    seed(&e->actuator_lag.tau);
    seed(&e->actuator_lag.dead_time);
  } else if (effect == "rig_compliance") {
    e->rig_compliance.enabled = true;
    seed(&e->rig_compliance.k);
  } else if (effect == "sensor_offset") {
    e->sensor_offset.enabled = true;
    for (int k = 0; k < 6; ++k) seed(&e->sensor_offset.offset(k));
    seed(&e->sensor_offset.scale);
  }
  for (const std::string& name : hard_points) {
    seed_always(FindParameter(p, name));
  }
  e->bushing_damping.at = e->hysteresis.at = e->progressive_stiffness.at = at;
  return d;
}

// The worst relative difference between the tangent-linear plant's sensed
// sensitivities and the Jet reference's over a ramp up and back down
// (hysteresis reverses), with `effect` enabled (see SeedEffect).
double WorstPlantDifference(const std::string& effect, bool seed_effect,
                            const BushingSet& at = kEveryBushing,
                            const std::vector<std::string>& hard_points = {}) {
  const KcrigConfig config = SourceConfig();
  const double h = 1e-3;
  SuspensionParameters<Jet8> p = config.model.Cast<Jet8>();
  BasicPlantEffects<Jet8> e = PlantEffects().Cast<Jet8>();
  const int directions =
      SeedEffect(effect, seed_effect, at, hard_points, &e, &p);
  BasicRigPlant<Jet8> tangent_linear(p, e, h, 0.02);
  BasicRigPlant<Jet8, SuspensionModel<Jet8>> reference(p, e, h, 0.02);
  auto force = [](double t) {
    const double level = t < 0.3 ? -1 + t / 0.15 : 1 - (t - 0.3) / 0.15;
    return Vec3<Jet8>(Jet8(1500 * level), Jet8(2500 * level), Jet8(0.0));
  };
  EXPECT_TRUE(tangent_linear.Settle(force(0), Jet8(-0.2)).ok());
  EXPECT_TRUE(reference.Settle(force(0), Jet8(-0.2)).ok());
  std::vector<double> scale(6 * directions, 0.0), difference(scale);
  for (int n = 1; n <= 600; ++n) {
    tangent_linear.Step(force(n * h));
    reference.Step(force(n * h));
    const Vec6<Jet8> a = reference.Sensed();
    const Vec6<Jet8> b = tangent_linear.Sensed();
    for (int k = 0; k < 6; ++k) {
      EXPECT_NEAR(a(k).a, b(k).a, 1e-12 * (1 + std::abs(a(k).a))) << effect;
      for (int d = 0; d < directions; ++d) {
        scale[6 * d + k] = std::max(scale[6 * d + k], std::abs(a(k).v[d]));
        difference[6 * d + k] =
            std::max(difference[6 * d + k], std::abs(a(k).v[d] - b(k).v[d]));
      }
    }
  }
  double worst = 0;
  for (size_t i = 0; i < scale.size(); ++i) {
    if (scale[i] > 0) worst = std::max(worst, difference[i] / scale[i]);
  }
  std::printf("%-22s %s worst relative difference %.3g\n", effect.c_str(),
              seed_effect ? "seeded" : "fixed ", worst);
  return worst;
}

// The diagnosis' plant: every effect's sensitivities (its own parameters
// and a stiffness) by the tangent-linear model equal the Jet reference's.
TEST(TangentLinearTest, EveryPlantEffectMatchesTheJets) {
  for (std::string_view name : kEffectNames) {
    EXPECT_LE(WorstPlantDifference(std::string(name), true), 1e-10) << name;
  }
}

// An effect acting with fixed parameters (its hooks carry values but no
// tangents): a stiffness's sensitivities, exactly.
TEST(TangentLinearTest, EffectsWithFixedParametersMatchTheJets) {
  for (std::string_view name : kEffectNames) {
    EXPECT_LE(WorstPlantDifference(std::string(name), false), 1e-10) << name;
  }
}

// A bushing effect placed in some bushings (component-level candidates):
// the same exactness.
TEST(TangentLinearTest, BushingEffectsPlacedInSomeBushingsMatchTheJets) {
  const BushingSet o1_and_p = {true, false, false, false, true};
  for (const char* name :
       {"bushing_damping", "hysteresis", "progressive_stiffness"}) {
    EXPECT_LE(WorstPlantDifference(name, true, o1_and_p), 1e-10) << name;
  }
}

// Hard points with a bushing effect's hooks carrying tangents too (a freed
// hard point fitted beside an effect): the chassis and carrier points of a
// bushing with the effect, and the spring's carrier point.
TEST(TangentLinearTest, HardPointsWithBushingEffectsMatchTheJets) {
  for (const char* name :
       {"bushing_damping", "hysteresis", "progressive_stiffness"}) {
    EXPECT_LE(WorstPlantDifference(name, true, kEveryBushing,
                                   {"O1.z", "N1.y", "spring_carrier.y"}),
              1e-10)
        << name;
  }
}

}  // namespace
}  // namespace kcrig
