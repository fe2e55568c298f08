// The paper's first estimation (4001 samples x 6 channels, 5 bushing
// stiffnesses, truth 3.6e6..4.4e6 N/m, start 5 % off, noise-free) solved by
//  - kcrig: Ceres Levenberg-Marquardt on exact Jet sensitivities;
//  - MINPACK lmder (the code the paper used) fed by a forward-difference
//    Jacobian (step sqrt(machine epsilon), MINPACK's own default);
//  - Ceres with numeric (central) differentiation of the same residuals;
// and the covariance/identifiability analysis alone. Counters: the largest
// relative parameter error and the number of trajectory simulations.
// Run: build/bin/estimator_bench --benchmark_format=json
#include <minpack.h>

#include <cmath>
#include <limits>
#include <vector>

#include "benchmark/benchmark.h"
#include "ceres/ceres.h"
#include "estimator/estimator.h"
#include "estimator/internal/fit_problem.h"
#include "estimator/trajectory_residual.h"
#include "rt_core/model/measurement_noise.h"
#include "rt_core/model/model_config.h"
#include "rt_core/model/simulation.h"

namespace kcrig {
namespace {

struct Setup {
  KcrigConfig config;
  SuspensionParameters<double> truth;
  std::vector<Experiment> experiments{1};
  std::vector<int> indices;
  std::vector<double> initial_scaled;  // start 5 % off the truth

  Setup() {
    if (!LoadConfig(KCRIG_BENCH_CONFIG_DIR, &config).ok()) std::abort();
    truth = config.model;
    const double values[kNumBushings] = {3.6e6, 4.4e6, 3.9e6, 4.25e6, 3.75e6};
    for (int i = 0; i < kNumBushings; ++i) {
      truth.bushings[i].stiffness = values[i];
      initial_scaled.push_back(values[i] * (i % 2 ? 0.95 : 1.05) /
                               config.model.bushings[i].stiffness);
    }
    const ExperimentConfig& e = config.experiment;
    std::vector<TrajectorySample<double>> samples;
    SimulateTrajectory(SuspensionModel<double>(truth),
                       RampExcitation<double>{e.phi, e.z_a, e.fmax, e.duration},
                       SimulationOptions{}, &samples);
    RunLog log;
    log.metadata.rate = 1.0 / e.step;
    log.metadata.excitation.z_a = e.z_a;
    log.metadata.sigma_position = e.sigma_position;
    log.metadata.sigma_angle = e.sigma_angle;
    for (const auto& s : samples) {
      LogSample sample;
      sample.t = s.t;
      sample.force = s.force;
      sample.y = s.y;
      log.samples.push_back(sample);
    }
    if (!MakeExperiment("bench", log, e.step, &experiments[0]).ok())
      std::abort();
    if (!ResolveParameters(config.model, EstimatorOptions{}.parameters,
                           &indices)
             .ok()) {
      std::abort();
    }
  }

  double MaxRelativeError(const double* scaled) const {
    double worst = 0;
    for (int i = 0; i < kNumBushings; ++i) {
      const double value = scaled[i] * config.model.bushings[i].stiffness;
      worst = std::max(worst, std::abs(value - truth.bushings[i].stiffness) /
                                  truth.bushings[i].stiffness);
    }
    return worst;
  }
};

const Setup& GetSetup() {
  static const Setup setup;
  return setup;
}

void BM_KcrigExactSensitivityLM(benchmark::State& state) {
  const Setup& s = GetSetup();
  EstimationResult result;
  std::vector<double> initial;
  for (int i = 0; i < kNumBushings; ++i) {
    initial.push_back(s.initial_scaled[i] *
                      s.config.model.bushings[i].stiffness);
  }
  for (auto _ : state) {
    Estimate(s.config.model, s.experiments, EstimatorOptions{}, initial,
             s.config.experiment.step, &result);
  }
  std::vector<double> scaled;
  for (const auto& p : result.parameters) scaled.push_back(p.value / p.nominal);
  state.counters["max_rel_error"] = s.MaxRelativeError(scaled.data());
  state.counters["iterations"] = result.iterations;
}
BENCHMARK(BM_KcrigExactSensitivityLM)->Unit(benchmark::kMillisecond);

// MINPACK's callback has no user pointer: the residual lives in a global.
const TrajectoryResidual* g_residual = nullptr;
int g_simulations = 0;

void Residuals(const double* x, double* f) {
  const double* blocks[kNumBushings];
  for (int i = 0; i < kNumBushings; ++i) blocks[i] = &x[i];
  ++g_simulations;
  if (!g_residual->Evaluate(blocks, f, nullptr)) {
    for (int r = 0; r < g_residual->num_residuals(); ++r) f[r] = 1e10;
  }
}

// lmder callback: iflag 1 residuals, 2 Jacobian by forward differences
// (column-major fjac, as MINPACK expects) from the residuals at x that
// lmder passes in fvec, as lmdif's fdjac2 does: n simulations per Jacobian.
void LmderCallback(int* m, int* n, double* x, double* fvec, double* fjac,
                   int* ldfjac, int* iflag) {
  if (*iflag == 1) {
    Residuals(x, fvec);
    return;
  }
  if (*iflag != 2) return;
  std::vector<double> shifted(*m);
  const double eps = std::sqrt(std::numeric_limits<double>::epsilon());
  for (int j = 0; j < *n; ++j) {
    const double saved = x[j];
    const double h = eps * std::max(std::abs(saved), 1.0);
    x[j] = saved + h;
    Residuals(x, shifted.data());
    x[j] = saved;
    for (int i = 0; i < *m; ++i) {
      fjac[j * *ldfjac + i] = (shifted[i] - fvec[i]) / h;
    }
  }
}

void BM_MinpackLmderForwardDifference(benchmark::State& state) {
  const Setup& s = GetSetup();
  EstimatorOptions options;
  TrajectoryResidual residual(&s.config.model, s.indices, options.channels,
                              &s.experiments[0], s.config.experiment.step);
  g_residual = &residual;
  int m = residual.num_residuals(), n = kNumBushings;
  std::vector<double> x, fvec(m), fjac(static_cast<size_t>(m) * n), diag(n),
      qtf(n), wa1(n), wa2(n), wa3(n), wa4(m);
  std::vector<int> ipvt(n);
  int info = 0, nfev = 0, njev = 0;
  for (auto _ : state) {
    x = s.initial_scaled;
    g_simulations = 0;
    double ftol = 1e-10, xtol = 1e-12, gtol = 0, factor = 100;
    int maxfev = 1000, mode = 1, nprint = 0, ldfjac = m;
    lmder_(LmderCallback, &m, &n, x.data(), fvec.data(), fjac.data(), &ldfjac,
           &ftol, &xtol, &gtol, &maxfev, diag.data(), &mode, &factor, &nprint,
           &info, &nfev, &njev, ipvt.data(), qtf.data(), wa1.data(), wa2.data(),
           wa3.data(), wa4.data());
  }
  state.counters["max_rel_error"] = s.MaxRelativeError(x.data());
  state.counters["simulations"] = g_simulations;
  state.counters["info"] = info;
}
BENCHMARK(BM_MinpackLmderForwardDifference)->Unit(benchmark::kMillisecond);

struct NumericResidual {
  const TrajectoryResidual* residual;
  bool operator()(double const* const* parameters, double* residuals) const {
    return residual->Evaluate(parameters, residuals, nullptr);
  }
};

void BM_CeresNumericDiffLM(benchmark::State& state) {
  const Setup& s = GetSetup();
  EstimatorOptions options;
  TrajectoryResidual residual(&s.config.model, s.indices, options.channels,
                              &s.experiments[0], s.config.experiment.step);
  std::vector<double> x;
  int iterations = 0;
  for (auto _ : state) {
    x = s.initial_scaled;
    ceres::Problem::Options problem_options;
    ceres::Problem problem(problem_options);
    auto* cost = new ceres::DynamicNumericDiffCostFunction<NumericResidual>(
        new NumericResidual{&residual});
    std::vector<double*> blocks;
    for (double& v : x) {
      cost->AddParameterBlock(1);
      blocks.push_back(&v);
    }
    cost->SetNumResiduals(residual.num_residuals());
    problem.AddResidualBlock(cost, nullptr, blocks);
    ceres::Solver::Options solver;
    solver.linear_solver_type = ceres::DENSE_QR;
    solver.function_tolerance = options.function_tolerance;
    solver.parameter_tolerance = options.parameter_tolerance;
    solver.gradient_tolerance = options.gradient_tolerance;
    solver.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(solver, &problem, &summary);
    iterations = static_cast<int>(summary.iterations.size()) - 1;
  }
  state.counters["max_rel_error"] = s.MaxRelativeError(x.data());
  state.counters["iterations"] = iterations;
}
BENCHMARK(BM_CeresNumericDiffLM)->Unit(benchmark::kMillisecond);

void BM_CovarianceAndIdentifiability(benchmark::State& state) {
  const Setup& s = GetSetup();
  EstimatorOptions options;
  FitProblem problem(s.config.model, s.experiments, options,
                     s.config.experiment.step, s.indices);
  Eigen::MatrixXd jacobian;
  problem.Evaluate(std::vector<double>(kNumBushings, 1.0), nullptr, nullptr,
                   &jacobian);
  EstimationResult result;
  for (int i = 0; i < kNumBushings; ++i) {
    ParameterEstimate p;
    p.name = options.parameters[i];
    p.nominal = p.value = s.config.model.bushings[i].stiffness;
    result.parameters.push_back(p);
  }
  result.sigma_hat = 1.0;
  for (auto _ : state) {
    AnalyzeUncertainty(jacobian, options, &result);
    benchmark::DoNotOptimize(result.covariance.data());
  }
  state.counters["rows"] = static_cast<double>(jacobian.rows());
}
BENCHMARK(BM_CovarianceAndIdentifiability)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace kcrig

BENCHMARK_MAIN();
