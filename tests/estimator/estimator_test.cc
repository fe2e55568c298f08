// Acceptance of the estimator issue: re-identification, calibrated
// covariance, non-identifiable set-ups reported.
#include "estimator/estimator.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "estimator/estimate_io.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/support/synthetic.h"
#include "tests/support/temp_dir_test.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

SyntheticSpec PaperInitialSpec(const KcrigConfig& config) {
  return {config.experiment.phi, config.experiment.z_a, config.experiment.fmax,
          config.experiment.duration};
}

// The bushing stiffnesses of `truth`, each times `factor`: a start off it.
std::vector<double> ScaledStiffnesses(const SuspensionParameters<double>& truth,
                                      double factor) {
  std::vector<double> values;
  for (int i = 0; i < kNumBushings; ++i) {
    values.push_back(truth.bushings[i].stiffness * factor);
  }
  return values;
}

// Acceptance 1: the paper's first estimation, noise-free, start 5 % off.
TEST(EstimatorTest, ReidentifiesDistinctStiffnessesFromNoiseFreeData) {
  const KcrigConfig config = SourceConfig();
  const SuspensionParameters<double> truth = DistinctBushingTruth(config.model);
  const std::vector<Experiment> experiments = {
      SyntheticExperiment(config, truth, PaperInitialSpec(config))};
  std::vector<double> initial;
  for (int i = 0; i < kNumBushings; ++i) {
    // Alternate the sign so the start is not a pure rescaling.
    initial.push_back(truth.bushings[i].stiffness * (i % 2 ? 0.95 : 1.05));
  }
  EstimationResult result;
  const Status status = Estimate(config.model, experiments, EstimatorOptions{},
                                 initial, config.experiment.step, &result);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_TRUE(result.converged) << result.termination;
  std::printf("noise-free re-identification (%d iterations, %.3f s):\n",
              result.iterations, result.seconds);
  for (int i = 0; i < kNumBushings; ++i) {
    const double relative =
        std::abs(result.parameters[i].value - truth.bushings[i].stiffness) /
        truth.bushings[i].stiffness;
    std::printf("  %s  truth %.1f N/mm  estimate %.6f N/mm  rel. error %.2e\n",
                result.parameters[i].name.c_str(),
                truth.bushings[i].stiffness * 1e-3,
                result.parameters[i].value * 1e-3, relative);
    EXPECT_LE(relative, 1e-6) << result.parameters[i].name;
  }
  EXPECT_EQ(result.rank, kNumBushings);
}

// Acceptance 3 (SVD part): an excitation that leaves link P unloaded cannot
// identify its bushing; the estimator says so and still reports the others.
TEST(EstimatorTest, ReportsTheBushingOfAnUnloadedLink) {
  const KcrigConfig config = SourceConfig();
  SyntheticSpec spec = PaperInitialSpec(config);
  spec.phi = DirectionUnloadingLink(config, kP);
  std::printf("  link P unloaded at phi = %.2f deg\n", spec.phi * 180 / M_PI);
  const std::vector<Experiment> experiments = {
      SyntheticExperiment(config, config.model, spec)};
  std::vector<double> initial;
  for (int i = 0; i < kNumBushings; ++i) {
    initial.push_back(config.model.bushings[i].stiffness * 1.02);
  }
  EstimationResult result;
  const Status status = Estimate(config.model, experiments, EstimatorOptions{},
                                 initial, config.experiment.step, &result);
  ASSERT_TRUE(status.ok()) << status.message();
  for (const std::string& c : result.unidentifiable_combinations) {
    std::printf("  not identifiable: %s\n", c.c_str());
  }
  std::printf("  singular values:");
  for (int i = 0; i < result.singular_values.size(); ++i) {
    std::printf(" %.3g", result.singular_values(i));
  }
  std::printf("\n");
  ASSERT_EQ(result.unidentifiable_combinations.size(), 1u);
  EXPECT_NE(result.unidentifiable_combinations[0].find("c_P"),
            std::string::npos);
  for (const ParameterEstimate& p : result.parameters) {
    EXPECT_EQ(p.identifiable, p.name != "c_P") << p.name;
  }
  // With the paper's direction the same estimator finds all five.
  const std::vector<Experiment> paper = {
      SyntheticExperiment(config, config.model, PaperInitialSpec(config))};
  ASSERT_TRUE(Estimate(config.model, paper, EstimatorOptions{}, initial,
                       config.experiment.step, &result)
                  .ok());
  EXPECT_TRUE(result.unidentifiable_combinations.empty());
}

// Several experiments are fitted jointly: two designs together determine the
// stiffnesses better than either alone.
TEST(EstimatorTest, JointFitOfTwoExperimentsIsTighterThanEither) {
  const KcrigConfig config = SourceConfig();
  const SuspensionParameters<double> truth = DistinctBushingTruth(config.model);
  SyntheticSpec lateral = PaperInitialSpec(config);
  lateral.noise = true;
  lateral.seed = 21;
  SyntheticSpec longitudinal = lateral;
  longitudinal.phi = 10.0 * M_PI / 180.0;
  longitudinal.seed = 22;
  const Experiment a = SyntheticExperiment(config, truth, lateral);
  const Experiment b = SyntheticExperiment(config, truth, longitudinal);
  std::vector<double> initial;
  for (int i = 0; i < kNumBushings; ++i) {
    initial.push_back(truth.bushings[i].stiffness * 1.03);
  }
  EstimationResult only_a, only_b, joint;
  ASSERT_TRUE(Estimate(config.model, {a}, EstimatorOptions{}, initial,
                       config.experiment.step, &only_a)
                  .ok());
  ASSERT_TRUE(Estimate(config.model, {b}, EstimatorOptions{}, initial,
                       config.experiment.step, &only_b)
                  .ok());
  ASSERT_TRUE(Estimate(config.model, {a, b}, EstimatorOptions{}, initial,
                       config.experiment.step, &joint)
                  .ok());
  EXPECT_EQ(joint.num_residuals, only_a.num_residuals + only_b.num_residuals);
  std::printf("  standard errors [N/mm]: phi 85 deg | phi 10 deg | joint\n");
  for (int i = 0; i < kNumBushings; ++i) {
    const double se_a = only_a.parameters[i].standard_error;
    const double se_b = only_b.parameters[i].standard_error;
    const double se_joint = joint.parameters[i].standard_error;
    std::printf("  %-5s %8.3f %8.3f %8.3f\n", joint.parameters[i].name.c_str(),
                se_a * 1e-3, se_b * 1e-3, se_joint * 1e-3);
    EXPECT_LT(se_joint, std::min(se_a, se_b)) << joint.parameters[i].name;
    EXPECT_LE(joint.parameters[i].ci95_low, truth.bushings[i].stiffness);
    EXPECT_GE(joint.parameters[i].ci95_high, truth.bushings[i].stiffness);
  }
}

// Without a load cell the log has no force columns; the estimator drives the
// model with the sidecar's commanded ramp instead.
TEST(EstimatorTest, LogWithoutLoadCellUsesTheCommandedRamp) {
  const KcrigConfig config = SourceConfig();
  const SuspensionParameters<double> truth = DistinctBushingTruth(config.model);
  RunLog log = SyntheticLog(config, truth, PaperInitialSpec(config));
  log.has_measured_force = false;
  const std::string path = ::testing::TempDir() + "kcrig_no_load_cell.csv";
  ASSERT_TRUE(WriteRunLog(path, log).ok());
  Experiment experiment;
  const Status loaded = LoadExperiment(path, config, "", &experiment);
  ASSERT_TRUE(loaded.ok()) << loaded.message();
  for (size_t j = 0; j < log.samples.size(); j += 500) {
    EXPECT_LT((experiment.forces[j] - log.samples[j].force).norm(), 1e-9);
  }
  const std::vector<double> initial = ScaledStiffnesses(truth, 1.05);
  EstimationResult result;
  ASSERT_TRUE(Estimate(config.model, {experiment}, EstimatorOptions{}, initial,
                       config.experiment.step, &result)
                  .ok());
  for (int i = 0; i < kNumBushings; ++i) {
    EXPECT_NEAR(result.parameters[i].value / truth.bushings[i].stiffness, 1.0,
                1e-6);
  }
}

// A structure still creeping from the last run moves during the tare: the
// log's tare gives its mean and the pose at the first row.
TEST(EstimatorTest, ARigLogsTareGivesItsMeanAndItsFirstRowsPose) {
  const KcrigConfig config = SourceConfig();
  RunLog log = SyntheticLog(config, DistinctBushingTruth(config.model),
                            PaperInitialSpec(config));
  const double t0 = log.samples.front().t;
  const Vec6<double> first = log.samples.front().y;
  const Vec6<double> drift = Vec6<double>::Constant(-1e-4);  // per second
  for (size_t j = 0; j < log.samples.size(); ++j) {
    LogSample& s = log.samples[j];
    s.phase = j < 200 ? "tare" : j < 400 ? "lead_in" : "settle";
    if (j < 200) s.y = first + drift * (s.t - t0);
  }
  Experiment experiment;
  ASSERT_TRUE(
      MakeExperiment("run.csv", log, config.experiment.step, &experiment).ok());
  ASSERT_TRUE(experiment.tare.has_value());
  EXPECT_LT((experiment.tare->at_start - first).cwiseAbs().maxCoeff(), 1e-12);
  // The mean sits at the tare's middle: 99.5 rows of drift on.
  const double middle = 99.5 * (log.samples[1].t - t0);
  EXPECT_LT(
      (experiment.tare->mean - (first + drift * middle)).cwiseAbs().maxCoeff(),
      1e-12);
  EXPECT_EQ(experiment.memory_rows, 400);
}

class EstimateFileTest : public TempDirTest {};

// est.json's rig_initial_state reads back as it was written (mm and deg
// back to SI, null Dahl forces as NaN); a broken entry is one line naming
// the field.
TEST_F(EstimateFileTest, InitialStatesReadBackAsWritten) {
  EstimationResult result;
  result.parameters = {
      {"c_O1", "N/m", 3.6e6, 3.6e6, 3.7e6, 1e3, 3.69e6, 3.71e6}};
  result.covariance = result.correlation = result.information =
      Eigen::MatrixXd::Identity(1, 1);
  result.singular_values = Eigen::VectorXd::Ones(1);
  TarePose tare;
  tare.mean << -53e-6, 1e-6, 2e-6, 1e-4, -2e-4, -3.3e-4;
  tare.at_start = tare.mean * 2;
  // The four start kinds: equilibrium, Dahl forces, first-row pose, both.
  result.initial_states.resize(4);
  for (LogInitialState& s : result.initial_states) s.tare = tare;
  result.initial_states[1].dahl_forces = {0, -305.5, 0, NAN, 12.25};
  result.initial_states[2].from_first_row_pose = true;
  result.initial_states[3].dahl_forces = {1, 2, 3, 4, 5};
  result.initial_states[3].from_first_row_pose = true;
  const std::string path = Path("est.json");
  const std::vector<std::string> logs = {"a/run.csv", "b/run.csv", "c/run.csv",
                                         "d/run.csv"};
  const std::string json = EstimationResultToJson(result, logs, {}, {});
  std::ofstream(path) << json;
  EstimateFile back;
  ASSERT_TRUE(ReadEstimateFile(path, &back).ok());
  EXPECT_EQ(back.logs, logs);
  ASSERT_EQ(back.initial_states.size(), 4u);
  for (int i = 0; i < 4; ++i) {
    const LogInitialState& s = back.initial_states[i];
    ASSERT_TRUE(s.tare.has_value()) << i;
    EXPECT_LT((s.tare->mean - tare.mean).cwiseAbs().maxCoeff(), 1e-15) << i;
    EXPECT_EQ(s.from_first_row_pose, i >= 2) << i;
    EXPECT_EQ(s.dahl_forces.size(), i % 2 == 1 ? 5u : 0u) << i;
    // The first-row pose where the model started there, else unknown.
    if (i >= 2) {
      EXPECT_LT((s.tare->at_start - tare.at_start).cwiseAbs().maxCoeff(), 1e-15)
          << i;
    } else {
      EXPECT_TRUE(s.tare->at_start.array().isNaN().all()) << i;
    }
  }
  EXPECT_EQ(back.initial_states[1].dahl_forces[1], -305.5);
  EXPECT_TRUE(std::isnan(back.initial_states[1].dahl_forces[3]));
  EXPECT_EQ(back.initial_states[3].dahl_forces,
            std::vector<double>({1, 2, 3, 4, 5}));
  std::string broken = json;
  broken.replace(broken.find("\"dahl_forces\""), 13, "\"friction\"");
  std::ofstream(path) << broken;
  const Status status = ReadEstimateFile(path, &back);
  EXPECT_NE(status.message().find(path + ": rig_initial_state[1].start:"),
            std::string::npos)
      << status.message();
}

// One parameter estimate, as est.json, campaign.json and diag.json write it,
// reads back as written: every field, an interval not given as not given
// (NaN) and the parameter not identifiable; a missing value is one line
// naming where, a field of another type reads as not given.
TEST_F(EstimateFileTest, AParameterEstimateReadsBackAsWritten) {
  ParameterEstimate given = {"c_O1", "N/m",  3.6e6, 3.5e6, 3.7e6, 1e3,
                             3.69e6, 3.71e6, -6.5,  true,  true,  250.0};
  ParameterEstimate unknown = {
      "hysteresis.force", "N",      100, 90,    120,   INFINITY,
      -INFINITY,          INFINITY, NAN, false, false, 0};
  // Weakly determined: a finite interval, but not identifiable.
  ParameterEstimate weak = given;
  weak.identifiable = false;
  for (const ParameterEstimate& p : {given, unknown, weak}) {
    const nlohmann::json node =
        nlohmann::json::parse(ParameterEstimateToJson(p).dump());
    ParameterEstimate back;
    ASSERT_TRUE(
        ReadParameterEstimate(node, "f.json: parameters[0]", &back).ok());
    EXPECT_EQ(back.name, p.name);
    EXPECT_EQ(back.unit, p.unit);
    EXPECT_EQ(back.nominal, p.nominal);
    EXPECT_EQ(back.initial, p.initial);
    EXPECT_EQ(back.value, p.value);
    EXPECT_EQ(back.identifiable, p.identifiable);
    EXPECT_EQ(back.at_bound, p.at_bound);
    EXPECT_EQ(back.discretisation_bias, p.discretisation_bias);
    if (std::isfinite(p.standard_error)) {
      EXPECT_EQ(back.standard_error, p.standard_error);
      EXPECT_EQ(back.ci95_low, p.ci95_low);
      EXPECT_EQ(back.ci95_high, p.ci95_high);
      EXPECT_EQ(back.log10_inverse_information, p.log10_inverse_information);
    } else {
      EXPECT_TRUE(node["ci95"][0].is_null() && node["ci95"][1].is_null());
      EXPECT_TRUE(std::isnan(back.standard_error));
      EXPECT_TRUE(std::isnan(back.ci95_low) && std::isnan(back.ci95_high));
      EXPECT_TRUE(std::isnan(back.log10_inverse_information));
    }
  }
  nlohmann::json node =
      nlohmann::json::parse(ParameterEstimateToJson(given).dump());
  node["unit"] = 5;
  node["identifiable"] = "yes";
  ParameterEstimate back;
  ASSERT_TRUE(ReadParameterEstimate(node, "f.json: parameters[0]", &back).ok());
  EXPECT_EQ(back.unit, "");
  EXPECT_TRUE(back.identifiable);  // from its interval
  node.erase("value");
  EXPECT_EQ(
      ReadParameterEstimate(node, "f.json: parameters[0]", &back).message(),
      "f.json: parameters[0]: missing field 'value'");
  node["value"] = nullptr;
  EXPECT_EQ(
      ReadParameterEstimate(node, "f.json: parameters[0]", &back).message(),
      "f.json: parameters[0].value: unexpected type (null)");
}

TEST(EstimatorTest, ParameterSelectionIsChecked) {
  KcrigConfig config = SourceConfig();
  std::vector<int> indices;
  EXPECT_TRUE(
      ResolveParameters(config.model, {"c_P", "k_spring"}, &indices).ok());
  EXPECT_EQ(indices.size(), 2u);
  config.model.bushings[kO1].damping = 0.0;
  const Status zero = ResolveParameters(config.model, {"d_O1"}, &indices);
  EXPECT_EQ(zero.message(),
            "parameter 'd_O1' has nominal value 0 and cannot be scaled");
  EXPECT_FALSE(ResolveParameters(config.model,
                                 {"c_O1", "c_O2", "c_V1", "c_V2", "c_P",
                                  "k_spring", "d_damper", "mass", "Jxx"},
                                 &indices)
                   .ok());
}

// A callback that asks to stop ends the fit at that iteration with the
// interrupted status; it saw the solver's iterations until then.
TEST(EstimatorTest, AnAbortingCallbackInterruptsTheFit) {
  const KcrigConfig config = SourceConfig();
  const SuspensionParameters<double> truth = DistinctBushingTruth(config.model);
  const std::vector<Experiment> experiments = {
      SyntheticExperiment(config, truth, PaperInitialSpec(config))};
  const std::vector<double> initial = ScaledStiffnesses(truth, 1.05);
  EstimatorOptions options;
  std::vector<IterationSummary> seen;
  options.callback = [&seen](const IterationSummary& summary) {
    seen.push_back(summary);
    return seen.size() == 2 ? CallbackReturn::kAbort
                            : CallbackReturn::kContinue;
  };
  EstimationResult result;
  const Status status = Estimate(config.model, experiments, options, initial,
                                 config.experiment.step, &result);
  EXPECT_EQ(status.message(), "estimation: interrupted");
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_EQ(seen[1].stage, "estimation: iteration 1");
  EXPECT_EQ(seen[1].done, 1);
  EXPECT_EQ(seen[1].total, options.max_iterations);
}

// A fit that needs more memory than the budget is refused before anything
// is allocated, in one line naming the log and both sizes; with the budget
// it needs, the same fit runs.
TEST(EstimatorTest, AFitTooLargeForTheBudgetIsRefused) {
  const KcrigConfig config = SourceConfig();
  const SuspensionParameters<double> truth = DistinctBushingTruth(config.model);
  std::vector<Experiment> experiments = {
      SyntheticExperiment(config, truth, PaperInitialSpec(config))};
  experiments[0].source = "long_run.csv";
  const std::vector<double> initial = ScaledStiffnesses(truth, 1.05);
  EstimatorOptions options;
  const std::uint64_t need = experiments[0].measured.size() *
                             (sizeof(Vec3<double>) + sizeof(Vec6<double>) +
                              sizeof(double) + 6 * 8 * (4 * 5 + 12));
  options.memory_budget_bytes = need - 1;
  EstimationResult result;
  const Status refused = Estimate(config.model, experiments, options, initial,
                                  config.experiment.step, &result);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.message().rfind(
                "long_run.csv: fitting 5 parameters to " +
                    std::to_string(experiments[0].measured.size()) +
                    " samples needs about ",
                0),
            0u)
      << refused.message();
  EXPECT_EQ(refused.message().find('\n'), std::string::npos);
  options.memory_budget_bytes = need;
  const Status fitted = Estimate(config.model, experiments, options, initial,
                                 config.experiment.step, &result);
  EXPECT_TRUE(fitted.ok()) << fitted.message();
}

}  // namespace
}  // namespace kcrig
