// The designer's costs on this machine:
//  - one criterion evaluation (4 s ramp trajectory + 5 exact sensitivities
//    + criterion), single and as a two-design batch on both cores;
//  - each optimizer from the paper's initial design (85 deg, -0.45 m) to
//    its optimum, D and A (counters: evaluations, optimum, criterion);
//  - the noise of Phi_A along a line through the initial design, ECnoise,
//    with exact and with forward-difference (1e-6) sensitivities;
//  - whole campaigns on the embedded SIL rig, without an effect and
//    adopting one (issue #17); the main job also on the pure model
//    simulation the embedded rig was before the SIL rig (issue #47: the
//    pair's ratio);
//  - the hysteresis model's fit to two SIL logs that remember, with and
//    without estimating each log's initial state (issue #47).
// Run: build/bin/designer_bench --benchmark_format=json
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <string>

#include "benchmark/benchmark.h"
#include "campaign/campaign.h"
#include "designer/internal/ecnoise.h"
#include "designer/optimizers.h"
#include "emulator/plant_config.h"
#include "emulator/sil_rig.h"
#include "emulator/simulated_run.h"
#include "estimator/effect_model.h"
#include "hil/campaign_rig.h"
#include "rt_core/model/channels.h"
#include "rt_core/model/model_config.h"
#include "rt_core/model/plant_effects.h"

namespace kcrig {
namespace {

struct Setup {
  KcrigConfig config;
  std::unique_ptr<InformationEvaluator> evaluator;
  DesignBounds bounds;
  Design initial;
  Setup() {
    if (!LoadConfig(KCRIG_BENCH_CONFIG_DIR, &config).ok()) std::abort();
    if (!InformationEvaluator::Create(
             config.model, {"c_O1", "c_O2", "c_V1", "c_V2", "c_P"},
             std::vector<double>(5, 4e6), config.experiment, Eigen::MatrixXd(),
             &evaluator)
             .ok()) {
      std::abort();
    }
    bounds = {config.experiment.phi_bounds, config.experiment.z_a_bounds};
    initial = {config.experiment.phi, config.experiment.z_a};
  }
};

const Setup& TheSetup() {
  static const Setup setup;
  return setup;
}

void BM_CriterionEvaluation(benchmark::State& state) {
  const Setup& s = TheSetup();
  for (auto _ : state) {
    Eigen::MatrixXd info;
    if (!s.evaluator->Information(s.initial, &info).ok()) std::abort();
    benchmark::DoNotOptimize(EvaluateCriterion(Criterion::kA, info).value);
  }
}
BENCHMARK(BM_CriterionEvaluation)->Unit(benchmark::kMillisecond)->UseRealTime();

// Two designs at once, one per core: the throughput of a stencil or grid.
void BM_CriterionEvaluationBatchOfTwo(benchmark::State& state) {
  const Setup& s = TheSetup();
  double shift = 0;
  for (auto _ : state) {
    ObjectiveOptions options;
    options.budget = 2;
    DesignObjective objective(s.evaluator.get(), Criterion::kA, s.bounds,
                              options);
    shift += 1e-6;
    benchmark::DoNotOptimize(
        objective.Evaluate({{0.3 + shift, 0.2}, {0.7 + shift, 0.4}}));
  }
  state.counters["evaluations_per_s"] =
      benchmark::Counter(2.0 * state.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_CriterionEvaluationBatchOfTwo)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_Optimizer(benchmark::State& state, const char* optimizer,
                  Criterion criterion) {
  const Setup& s = TheSetup();
  OptimizationResult result;
  for (auto _ : state) {
    ObjectiveOptions options;
    options.budget = 100;
    DesignObjective objective(s.evaluator.get(), criterion, s.bounds, options);
    if (!Optimize(optimizer, &objective, s.initial, OptimizerOptions(), &result)
             .ok()) {
      std::abort();
    }
  }
  state.counters["evaluations"] = result.evaluations;
  state.counters["criterion"] = result.best_value;
  state.counters["phi_deg"] = result.best.phi / kDegree;
  state.counters["z_a"] = result.best.z_a;
}
BENCHMARK_CAPTURE(BM_Optimizer, D_imfil, "imfil", Criterion::kD);
BENCHMARK_CAPTURE(BM_Optimizer, D_kriging, "kriging", Criterion::kD);
BENCHMARK_CAPTURE(BM_Optimizer, D_nlopt_direct_l, "nlopt:direct-l",
                  Criterion::kD);
BENCHMARK_CAPTURE(BM_Optimizer, A_imfil, "imfil", Criterion::kA);
BENCHMARK_CAPTURE(BM_Optimizer, A_kriging, "kriging", Criterion::kA);
BENCHMARK_CAPTURE(BM_Optimizer, A_nlopt_direct_l, "nlopt:direct-l",
                  Criterion::kA);
BENCHMARK_CAPTURE(BM_Optimizer, E_nlopt_slsqp_epigraph, "nlopt:slsqp",
                  Criterion::kE);
BENCHMARK_CAPTURE(BM_Optimizer, MM_nlopt_slsqp_epigraph, "nlopt:slsqp",
                  Criterion::kMM);

// Phi_A along the diagonal of the unit box through the initial design.
void BM_CriterionNoise(benchmark::State& state, bool finite_differences) {
  const Setup& s = TheSetup();
  NoiseEstimate estimate;
  for (auto _ : state) {
    estimate = EstimateNoiseAlongLine(
        [&](double t) {
          const Design d{
              s.initial.phi + t * (s.bounds.phi.upper - s.bounds.phi.lower),
              s.initial.z_a + t * (s.bounds.z_a.upper - s.bounds.z_a.lower)};
          Eigen::MatrixXd info;
          const Status status =
              finite_differences
                  ? s.evaluator->FiniteDifferenceInformation(d, 1e-6, &info)
                  : s.evaluator->Information(d, &info);
          if (!status.ok()) std::abort();
          return EvaluateCriterion(Criterion::kA, info).value;
        },
        1e-6);
  }
  state.counters["relative_noise"] = estimate.relative_noise;
  state.counters["estimated"] = estimate.verdict == NoiseVerdict::kEstimated;
}
BENCHMARK_CAPTURE(BM_CriterionNoise, exact_sensitivities, false)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_CriterionNoise, forward_differences_1e_6, true)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The embedded SIL rig as the campaign runs it (apps/campaign_command.cc).
RigRunner SilRigRunner(const KcrigConfig& config, const PlantConfig& plant) {
  auto sil = std::make_shared<SilRig>(config, plant);
  CampaignRig rig;
  const RigConnector connect = [sil](const std::string&,
                                     std::unique_ptr<RigInterface>* link) {
    *link = sil->Connect({});
    return Status::Ok();
  };
  if (!sil->Start().ok() || !CampaignRig::Open("sil", connect, sil->clock(),
                                               sil->Truth(), config, &rig)
                                 .ok()) {
    std::abort();
  }
  static const std::atomic<int> no_signal{0};
  return [rig](const RampExcitation<double>& excitation, int run,
               const std::string& csv) {
    return rig.Run(excitation, run, csv, &no_signal);
  };
}

// The embedded rig before the SIL rig: the pure model simulation of each
// ramp from rest, exact forces (the pair's reference).
RigRunner PureSimulationRunner(const KcrigConfig& config,
                               const PlantConfig& plant) {
  return [config, plant](const RampExcitation<double>& excitation, int run,
                         const std::string& csv) {
    SimulatedRunOptions options;
    options.rate = config.experiment.rate;
    options.step = plant.step;
    options.noise = plant.noise;
    options.seed = plant.seed + static_cast<std::uint64_t>(run);
    options.effects = plant.effects;
    options.geometry = GeometryFingerprint(config.model);
    RunLog log;
    const Status status =
        SimulateRun(plant.model, excitation, config.experiment, options, &log);
    return status.ok() ? WriteRunLog(csv, log) : status;
  };
}

// A whole campaign: `iterations` designed experiments after the first, the
// plant with `effect` ("" for none), the checks acting on their verdicts
// or not (`close_loop`), on the SIL rig or the pure simulation.
void BM_Campaign(benchmark::State& state, int iterations,
                 const std::string& effect, bool close_loop,
                 bool pure_simulation = false) {
  const Setup& s = TheSetup();
  PlantConfig plant;
  if (!LoadPlantConfig(KCRIG_BENCH_CONFIG_DIR, s.config.model, &plant).ok()) {
    std::abort();
  }
  if (!effect.empty() && !ParseEffect(effect, &plant.effects).ok()) {
    std::abort();
  }
  const std::string dir =
      (std::filesystem::temp_directory_path() / "kcrig_campaign_bench")
          .string();
  CampaignOptions options;
  options.iterations = iterations;
  options.close_loop = close_loop;
  std::string model;
  for (auto _ : state) {
    // A fresh rig per campaign, as `kcrig campaign` starts one.
    const RigRunner rig = pure_simulation
                              ? PureSimulationRunner(s.config, plant)
                              : SilRigRunner(s.config, plant);
    std::vector<CampaignIteration> iterations_run;
    if (!RunCampaign(s.config, options, rig, dir, &iterations_run).ok()) {
      std::abort();
    }
    model = iterations_run.back().model;
  }
  state.SetLabel("final model " + model);
  std::filesystem::remove_all(dir);
}
// The main job (`kcrig campaign`: 3 designed experiments after the first).
BENCHMARK_CAPTURE(BM_Campaign, default_no_effect, 3, "", true)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
// The same on the pure simulation (issue #47's pair: SIL <= 1.5x this).
BENCHMARK_CAPTURE(BM_Campaign, default_no_effect_pure_simulation, 3, "", true,
                  true)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
// Issue #17's figures: 3 experiments, without an effect (checks acting and
// not: their cost when nothing fails), and one that adopts an effect.
BENCHMARK_CAPTURE(BM_Campaign, 3_experiments_no_effect, 2, "", true)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_Campaign, 3_experiments_no_effect_no_diagnose, 2, "",
                  false)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_Campaign, 3_experiments_rig_compliance_adopted, 2,
                  "rig_compliance:k=2e7", true)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);

// Two SIL logs of the paper's experiment back to back, hysteresis in every
// bushing: the first from a fresh plant, the second from the friction the
// first left (issue #47's memory).
std::vector<Experiment> RememberingRigLogs(const KcrigConfig& config) {
  PlantConfig plant;
  if (!LoadPlantConfig(KCRIG_BENCH_CONFIG_DIR, config.model, &plant).ok() ||
      !ParseEffect("hysteresis:force=369,sigma=3.4e7", &plant.effects).ok()) {
    std::abort();
  }
  const RigRunner rig = SilRigRunner(config, plant);
  const std::string dir = (std::filesystem::temp_directory_path() /
                           ("kcrig_memory_bench_" + std::to_string(getpid())))
                              .string();
  std::filesystem::create_directories(dir);
  const ExperimentConfig& e = config.experiment;
  std::vector<Experiment> experiments(2);
  for (int run = 0; run < 2; ++run) {
    const std::string csv = dir + "/run" + std::to_string(run) + "/run.csv";
    if (!rig(RampExcitation<double>{e.phi, e.z_a, e.fmax, e.duration}, run, csv)
             .ok() ||
        !LoadExperiment(csv, config, "", &experiments[run]).ok()) {
      std::abort();
    }
  }
  std::filesystem::remove_all(dir);
  return experiments;
}

// The hysteresis model's fit to those logs (5 stiffnesses, the effect's
// force and sigma), each log started from the Dahl forces its tare shows
// (`initial_state`: BasicRigPlant::SettleAtRest) or from rest: the cost of
// estimating the initial state (issue #47: <= 1.2x).
void BM_HysteresisFitOfRigLogs(benchmark::State& state, bool initial_state) {
  const Setup& s = TheSetup();
  static const std::vector<Experiment> logs = RememberingRigLogs(s.config);
  std::vector<Experiment> experiments = logs;
  if (!initial_state) {
    for (Experiment& e : experiments) e.tare.reset();
  }
  // The box of the campaign's fits.
  const EstimatorOptions box;
  EffectModel model;
  if (!EffectModel::CreateNamed(s.config.model, "hysteresis", box.lower_scale,
                                box.upper_scale, &model)
           .ok()) {
    std::abort();
  }
  EffectFit fit;
  for (auto _ : state) {
    if (!FitEffectModel(model, experiments, {}, EffectFitOptions{},
                        s.config.experiment.step, &fit)
             .ok()) {
      std::abort();
    }
  }
  state.counters["fit_iterations"] = fit.result.iterations;
  state.counters["chi2_per_dof"] =
      fit.result.adequacy.chi_square / fit.result.adequacy.dof;
}
BENCHMARK_CAPTURE(BM_HysteresisFitOfRigLogs, initial_state_from_tare, true)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_HysteresisFitOfRigLogs, from_rest, false)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace kcrig

BENCHMARK_MAIN();
