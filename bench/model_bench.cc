// Speed of the model and its integrator (foundation issue):
//  - one semi-implicit Euler step with double (target: median <= 2 us);
//  - the paper's 4 s ramp at 1 kHz (4000 steps) with double (<= 10 ms) and
//    with exact sensitivities for the 5 bushing stiffnesses, by ceres::Jet
//    (the reference) and by the tangent-linear step that kcrig runs (#18:
//    target <= 2.5x double);
//  - the same trajectory with SUNDIALS CVODE (BDF) at the tolerance whose
//    error matches the semi-implicit Euler's at h = 1 ms, in the same run.
// Run: build/bin/model_bench --benchmark_format=json
#include <cmath>
#include <thread>
#include <vector>

#include "benchmark/benchmark.h"
#include "ceres/jet.h"
#include "rt_core/model/model_config.h"
#include "rt_core/model/simulation.h"
#include "rt_core/model/tangent_linear.h"
#include "tests/support/reference_integrators.h"

namespace kcrig {
namespace {

using Jet5 = ceres::Jet<double, kNumBushings>;

const KcrigConfig& Config() {
  static const KcrigConfig config = [] {
    KcrigConfig c;
    const Status status = LoadConfig(KCRIG_BENCH_CONFIG_DIR, &c);
    if (!status.ok()) std::abort();
    return c;
  }();
  return config;
}

RampExcitation<double> PaperRamp() {
  const ExperimentConfig& e = Config().experiment;
  return e.Excitation(e.phi, e.z_a);
}

void BM_SemiImplicitEulerStep(benchmark::State& state) {
  const SuspensionModel<double> model(Config().model);
  const RampExcitation<double> ramp = PaperRamp();
  ModelState<double> s;
  SolveStaticEquilibrium(model, ramp.LoadAt(0.0), 50, &s.y);
  const RigLoad<double> load = ramp.LoadAt(1e-3);
  for (auto _ : state) {
    SemiImplicitEulerStep(model, load, 1e-3, &s);
    benchmark::DoNotOptimize(s);
  }
}
BENCHMARK(BM_SemiImplicitEulerStep);

void BM_Trajectory4sDouble(benchmark::State& state) {
  const SuspensionModel<double> model(Config().model);
  std::vector<TrajectorySample<double>> samples;
  for (auto _ : state) {
    SimulateTrajectory(model, PaperRamp(), SimulationOptions{}, &samples);
    benchmark::DoNotOptimize(samples.data());
  }
  state.counters["steps"] = static_cast<double>(samples.size() - 1);
}
BENCHMARK(BM_Trajectory4sDouble)->Unit(benchmark::kMillisecond);

// The five stiffness sensitivities by the Jet reference (SuspensionModel)
// and by the tangent-linear step (TangentLinearModel, issue #18), one thread.
template <template <typename> class Model>
void BM_Trajectory4sSensitivities(benchmark::State& state) {
  SuspensionParameters<Jet5> parameters = Config().model.Cast<Jet5>();
  for (int i = 0; i < kNumBushings; ++i) {
    parameters.bushings[i].stiffness =
        Config().model.bushings[i].stiffness * Jet5(1.0, i);
  }
  const Model<Jet5> model(parameters);
  const RampExcitation<Jet5> ramp = PaperRamp().Cast<Jet5>();
  std::vector<TrajectorySample<Jet5>> samples;
  for (auto _ : state) {
    SimulateTrajectory(model, ramp, SimulationOptions{}, &samples);
    benchmark::DoNotOptimize(samples.data());
  }
}
void BM_Trajectory4sJetSensitivities(benchmark::State& state) {
  BM_Trajectory4sSensitivities<SuspensionModel>(state);
}
void BM_Trajectory4sTangentLinearSensitivities(benchmark::State& state) {
  BM_Trajectory4sSensitivities<TangentLinearModel>(state);
}
BENCHMARK(BM_Trajectory4sJetSensitivities)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Trajectory4sTangentLinearSensitivities)
    ->Unit(benchmark::kMillisecond);

// The five directions split over two threads, three (padded to an even
// Jet size) and two, each its own tangent-linear trajectory: what the
// estimator ran with Jets. Wall time, against one thread above.
template <int N>
void SimulateDirections(
    int first, int count,
    std::vector<TrajectorySample<ceres::Jet<double, N>>>* out) {
  using Jet = ceres::Jet<double, N>;
  SuspensionParameters<Jet> parameters = Config().model.Cast<Jet>();
  for (int k = 0; k < count; ++k) {
    Jet s(1.0);
    s.v[k] = 1.0;
    parameters.bushings[first + k].stiffness =
        Config().model.bushings[first + k].stiffness * s;
  }
  SimulateTrajectory(TangentLinearModel<Jet>(parameters),
                     PaperRamp().Cast<Jet>(), SimulationOptions{}, out);
}

void BM_Trajectory4sTangentLinearSensitivitiesTwoThreads(
    benchmark::State& state) {
  std::vector<TrajectorySample<ceres::Jet<double, 4>>> first;
  std::vector<TrajectorySample<ceres::Jet<double, 2>>> second;
  for (auto _ : state) {
    std::thread helper([&] { SimulateDirections<4>(0, 3, &first); });
    SimulateDirections<2>(3, 2, &second);
    helper.join();
    benchmark::DoNotOptimize(first.data());
    benchmark::DoNotOptimize(second.data());
  }
}
BENCHMARK(BM_Trajectory4sTangentLinearSensitivitiesTwoThreads)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Max error over 4 ms samples, in sensor sigmas, against a tight CVODE run.
struct Accuracy {
  double semi_implicit_error;
  double matched_rtol;
  double cvode_error;
};

const Accuracy& MatchedAccuracy() {
  static const Accuracy accuracy = [] {
    const SuspensionModel<double> model(Config().model);
    const RampExcitation<double> ramp = PaperRamp();
    Vec6<double> sigma;
    sigma << Vec3<double>::Constant(Config().experiment.sigma_position),
        Vec3<double>::Constant(Config().experiment.sigma_angle);
    ModelState<double> initial;
    SolveStaticEquilibrium(model, ramp.LoadAt(0.0), 50, &initial.y);
    std::vector<double> times;
    for (int j = 1; j <= 1000; ++j) times.push_back(4e-3 * j);
    const auto load = [&](double t) { return ramp.LoadAt(t); };
    auto error_of = [&](const std::vector<Vec6<double>>& y,
                        const std::vector<Vec6<double>>& ref) {
      double e = 0;
      for (size_t j = 0; j < ref.size(); ++j) {
        e = std::max(
            e, (y[j] - ref[j]).cwiseQuotient(sigma).cwiseAbs().maxCoeff());
      }
      return e;
    };
    CvodeOptions tight;
    tight.relative_tolerance = 1e-12;
    tight.absolute_tolerance_position = 1e-15;
    tight.absolute_tolerance_velocity = 1e-13;
    CvodeResult reference;
    IntegrateWithCvode(model, load, initial, times, tight, &reference);

    std::vector<TrajectorySample<double>> samples;
    SimulateTrajectory(model, ramp, SimulationOptions{}, &samples);
    std::vector<Vec6<double>> semi_implicit;
    for (size_t j = 1; j <= times.size(); ++j) {
      semi_implicit.push_back(samples[4 * j].y);
    }
    Accuracy a{error_of(semi_implicit, reference.y), 0, 0};
    // Loosest relative tolerance (absolute tolerances scaled with it) whose
    // error is at most the semi-implicit Euler's.
    for (double rtol = 1e-2; rtol >= 1e-12; rtol /= std::sqrt(10.0)) {
      CvodeOptions options;
      options.relative_tolerance = rtol;
      options.absolute_tolerance_position = rtol * 1e-3;
      options.absolute_tolerance_velocity = rtol * 1e-1;
      CvodeResult result;
      IntegrateWithCvode(model, load, initial, times, options, &result);
      const double e = error_of(result.y, reference.y);
      if (e <= a.semi_implicit_error) {
        a.matched_rtol = rtol;
        a.cvode_error = e;
        break;
      }
    }
    return a;
  }();
  return accuracy;
}

void BM_Trajectory4sCvodeMatchedAccuracy(benchmark::State& state) {
  const Accuracy& accuracy = MatchedAccuracy();
  const SuspensionModel<double> model(Config().model);
  const RampExcitation<double> ramp = PaperRamp();
  ModelState<double> initial;
  SolveStaticEquilibrium(model, ramp.LoadAt(0.0), 50, &initial.y);
  std::vector<double> times;
  for (int j = 1; j <= 4000; ++j) times.push_back(1e-3 * j);
  CvodeOptions options;
  options.relative_tolerance = accuracy.matched_rtol;
  options.absolute_tolerance_position = accuracy.matched_rtol * 1e-3;
  options.absolute_tolerance_velocity = accuracy.matched_rtol * 1e-1;
  CvodeResult result;
  for (auto _ : state) {
    IntegrateWithCvode(
        model, [&](double t) { return ramp.LoadAt(t); }, initial, times,
        options, &result);
    benchmark::DoNotOptimize(result.y.data());
  }
  state.counters["rtol"] = accuracy.matched_rtol;
  state.counters["cvode_error_sigma"] = accuracy.cvode_error;
  state.counters["semi_implicit_error_sigma"] = accuracy.semi_implicit_error;
  state.counters["cvode_steps"] = static_cast<double>(result.steps);
  state.counters["cvode_rhs_evals"] =
      static_cast<double>(result.rhs_evaluations);
}
BENCHMARK(BM_Trajectory4sCvodeMatchedAccuracy)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace kcrig

BENCHMARK_MAIN();
