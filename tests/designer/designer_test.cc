// Unit tests of the designer's pieces: criteria and their penalty, the
// epigraph functions, the budgeted objective, ECnoise, the kriging model,
// the criterion surface of a design step and design.json read back.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>

#include "designer/criteria.h"
#include "designer/criterion_surface.h"
#include "designer/design_io.h"
#include "designer/design_objective.h"
#include "designer/design_step.h"
#include "designer/information.h"
#include "designer/internal/ecnoise.h"
#include "designer/kriging.h"
#include "designer/optimizers.h"
#include "gtest/gtest.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

const std::vector<std::string> kBushings = {"c_O1", "c_O2", "c_V1", "c_V2",
                                            "c_P"};

std::unique_ptr<InformationEvaluator> NominalEvaluator(
    const KcrigConfig& config) {
  std::unique_ptr<InformationEvaluator> evaluator;
  const Status status = InformationEvaluator::Create(
      config.model, kBushings, std::vector<double>(5, 4e6), config.experiment,
      Eigen::MatrixXd(), &evaluator);
  EXPECT_TRUE(status.ok()) << status.message();
  return evaluator;
}

TEST(CriteriaTest, MatchTheirDefinitionsOnAKnownMatrix) {
  // I = Q diag(1, 4, 16) Q^T: I^-1 has eigenvalues 1, 1/4, 1/16.
  const Eigen::Matrix3d q =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())
          .toRotationMatrix();
  const Eigen::MatrixXd info =
      q * Eigen::Vector3d(1, 4, 16).asDiagonal() * q.transpose();
  const Eigen::MatrixXd inverse = info.inverse();
  EXPECT_NEAR(EvaluateCriterion(Criterion::kD, info).value, -std::log(64.0),
              1e-12);
  EXPECT_NEAR(EvaluateCriterion(Criterion::kA, info).value,
              (1 + 0.25 + 0.0625) / 3, 1e-12);
  EXPECT_NEAR(EvaluateCriterion(Criterion::kE, info).value, 1.0, 1e-12);
  EXPECT_NEAR(EvaluateCriterion(Criterion::kMM, info).value,
              inverse.diagonal().maxCoeff(), 1e-12);
  EXPECT_FALSE(EvaluateCriterion(Criterion::kD, info).singular);
  // The epigraph constraints' maximum is the max-type criterion.
  for (Criterion c : {Criterion::kE, Criterion::kMM}) {
    const std::vector<double> g = EvaluateCriterion(c, info).epigraph;
    EXPECT_NEAR(*std::max_element(g.begin(), g.end()),
                EvaluateCriterion(c, info).value, 1e-12);
  }
}

TEST(CriteriaTest, SingularInformationGivesAFiniteFlaggedPenalty) {
  const Eigen::MatrixXd zero = Eigen::MatrixXd::Zero(5, 5);
  Eigen::MatrixXd rank_one = Eigen::MatrixXd::Zero(5, 5);
  rank_one(0, 0) = 1e8;
  Eigen::MatrixXd not_finite = Eigen::MatrixXd::Identity(5, 5);
  not_finite(2, 3) = std::nan("");
  for (const Eigen::MatrixXd& info : {zero, rank_one, not_finite}) {
    for (Criterion c :
         {Criterion::kD, Criterion::kA, Criterion::kE, Criterion::kMM}) {
      const CriterionValue v = EvaluateCriterion(c, info);
      EXPECT_TRUE(std::isfinite(v.value)) << CriterionName(c);
      EXPECT_TRUE(v.singular) << CriterionName(c);
      for (double g : v.epigraph) EXPECT_TRUE(std::isfinite(g));
    }
  }
  // The documented floor: no information at all is 1e-6 per direction.
  EXPECT_NEAR(EvaluateCriterion(Criterion::kD, zero).value,
              -5 * std::log(kAbsoluteEigenvalueFloor), 1e-9);
  EXPECT_NEAR(EvaluateCriterion(Criterion::kE, zero).value,
              1 / kAbsoluteEigenvalueFloor, 1e-3);
  // Penalized is worse than any informative design.
  EXPECT_GT(
      EvaluateCriterion(Criterion::kA, rank_one).value,
      EvaluateCriterion(Criterion::kA, Eigen::MatrixXd::Identity(5, 5)).value);
}

TEST(CriteriaTest, ParsesNamesAndRejectsOthers) {
  Criterion c;
  EXPECT_TRUE(ParseCriterion("mm", &c).ok());
  EXPECT_EQ(c, Criterion::kMM);
  const Status bad = ParseCriterion("G", &c);
  EXPECT_FALSE(bad.ok());
  EXPECT_NE(bad.message().find("D, A, E or MM"), std::string::npos);
}

TEST(InformationTest, ZeroForceDesignIsSingularNotNan) {
  KcrigConfig config = SourceConfig();
  config.experiment.fmax = 0;
  config.experiment.duration = 0.2;
  const auto evaluator = NominalEvaluator(config);
  Eigen::MatrixXd info;
  ASSERT_TRUE(evaluator->Information({0.5, -0.2}, &info).ok());
  EXPECT_NEAR(info.norm(), 0.0, 1e-6);
  const CriterionValue v = EvaluateCriterion(Criterion::kA, info);
  EXPECT_TRUE(v.singular);
  EXPECT_TRUE(std::isfinite(v.value));
}

TEST(InformationTest, ExactAndFiniteDifferenceInformationAgree) {
  KcrigConfig config = SourceConfig();
  config.experiment.duration = 1.0;
  const auto evaluator = NominalEvaluator(config);
  Eigen::MatrixXd exact, fd;
  const Design design{1.2, -0.3};
  ASSERT_TRUE(evaluator->Information(design, &exact).ok());
  ASSERT_TRUE(evaluator->FiniteDifferenceInformation(design, 1e-6, &fd).ok());
  EXPECT_LT((exact - fd).norm(), 1e-4 * exact.norm());
}

TEST(InformationTest, RejectsBadParametersAndPrior) {
  const KcrigConfig config = SourceConfig();
  std::unique_ptr<InformationEvaluator> evaluator;
  EXPECT_FALSE(InformationEvaluator::Create(config.model, {"c_O1", "nope"},
                                            {4e6, 4e6}, config.experiment,
                                            Eigen::MatrixXd(), &evaluator)
                   .ok());
  EXPECT_FALSE(InformationEvaluator::Create(
                   config.model, kBushings, std::vector<double>(5, 1e3),
                   config.experiment, Eigen::MatrixXd(), &evaluator)
                   .ok());
  EXPECT_FALSE(InformationEvaluator::Create(
                   config.model, kBushings, std::vector<double>(5, 4e6),
                   config.experiment, Eigen::MatrixXd::Identity(3, 3),
                   &evaluator)
                   .ok());
}

TEST(DesignObjectiveTest, ZeroBudgetAndInvertedBoundsAreClearErrors) {
  const KcrigConfig config = SourceConfig();
  DesignBounds bounds{config.experiment.phi_bounds,
                      config.experiment.z_a_bounds};
  ObjectiveOptions options;
  options.budget = 0;
  Status status = DesignObjective::Validate(bounds, options);
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.message().find("--budget"), std::string::npos);
  options.budget = 10;
  std::swap(bounds.z_a.lower, bounds.z_a.upper);
  status = DesignObjective::Validate(bounds, options);
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.message().find("z_a"), std::string::npos);
}

TEST(DesignObjectiveTest, SpendsNoMoreThanTheBudgetAndRecordsEverything) {
  KcrigConfig config = SourceConfig();
  config.experiment.duration = 0.5;
  const auto evaluator = NominalEvaluator(config);
  ObjectiveOptions options;
  options.budget = 3;
  int batches = 0;
  options.callback = [&batches](const IterationSummary&) {
    ++batches;
    return CallbackReturn::kContinue;
  };
  DesignObjective objective(
      evaluator.get(), Criterion::kD,
      {config.experiment.phi_bounds, config.experiment.z_a_bounds}, options);
  const auto first = objective.Evaluate({{0.1, 0.1}, {0.9, 0.9}});
  ASSERT_EQ(first.size(), 2u);
  // Known points are free; the third new point is the last one paid for.
  const auto second = objective.Evaluate({{0.1, 0.1}, {0.5, 0.5}, {0.2, 0.2}});
  ASSERT_EQ(second.size(), 2u);
  EXPECT_EQ(second[0].value, first[0].value);
  EXPECT_EQ(objective.record().size(), 3u);
  EXPECT_EQ(objective.remaining(), 0);
  EXPECT_EQ(batches, 2);
  // Out-of-box points are clamped onto the bounds.
  const Design d = objective.ToDesign({-1, 2});
  EXPECT_EQ(d.phi, config.experiment.phi_bounds.lower);
  EXPECT_EQ(d.z_a, config.experiment.z_a_bounds.upper);
}

TEST(OptimizeTest, RejectsUnknownOptimizerAndStartOutsideBounds) {
  KcrigConfig config = SourceConfig();
  config.experiment.duration = 0.5;
  const auto evaluator = NominalEvaluator(config);
  DesignObjective objective(
      evaluator.get(), Criterion::kD,
      {config.experiment.phi_bounds, config.experiment.z_a_bounds},
      ObjectiveOptions());
  OptimizationResult result;
  EXPECT_FALSE(Optimize("simplex", &objective, {0.5, -0.2}, {}, &result).ok());
  EXPECT_FALSE(Optimize("imfil", &objective, {0.5, 0.3}, {}, &result).ok());
  EXPECT_TRUE(objective.record().empty());
}

// A callback that asks to stop ends the search after that batch, as if the
// budget were spent, and Optimize says it was interrupted.
TEST(OptimizeTest, AnAbortingCallbackInterruptsTheSearch) {
  KcrigConfig config = SourceConfig();
  config.experiment.duration = 0.5;
  const auto evaluator = NominalEvaluator(config);
  ObjectiveOptions options;
  int batches = 0;
  options.callback = [&batches](const IterationSummary& summary) {
    EXPECT_NE(summary.stage.find(" evaluations, best D "), std::string::npos)
        << summary.stage;
    return ++batches == 2 ? CallbackReturn::kAbort : CallbackReturn::kContinue;
  };
  DesignObjective objective(
      evaluator.get(), Criterion::kD,
      {config.experiment.phi_bounds, config.experiment.z_a_bounds}, options);
  OptimizationResult result;
  const Status status =
      Optimize("kriging", &objective, {config.experiment.phi, -0.2},
               OptimizerOptions(), &result);
  EXPECT_EQ(status.message(), "design: interrupted");
  EXPECT_EQ(batches, 2);
  EXPECT_TRUE(objective.interrupted());
  EXPECT_EQ(objective.remaining(), 0);
  // The start, then the initial Latin hypercube, then nothing.
  EXPECT_EQ(objective.record().size(),
            1u + OptimizerOptions().kriging_initial_points);
}

TEST(EcnoiseTest, RecoversTheNoiseOfASmoothFunctionPlusNoise) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double sigma = 1e-7;
  // Nine samples give a rough estimate: each within the factor 4 that
  // ECnoise itself accepts between orders, their median within 2.
  std::vector<double> estimates;
  for (int trial = 0; trial < 20; ++trial) {
    const NoiseEstimate e = EstimateNoiseAlongLine(
        [&](double t) { return 2.0 + std::sin(t) + sigma * normal(rng); },
        1e-6);
    if (e.verdict != NoiseVerdict::kEstimated) continue;
    estimates.push_back(e.noise);
    EXPECT_GT(e.noise, sigma / 4);
    EXPECT_LT(e.noise, sigma * 4);
  }
  ASSERT_GE(estimates.size(), 18u);
  std::nth_element(estimates.begin(), estimates.begin() + estimates.size() / 2,
                   estimates.end());
  const double median = estimates[estimates.size() / 2];
  EXPECT_GT(median, sigma / 2);
  EXPECT_LT(median, sigma * 2);
}

TEST(EcnoiseTest, ReportsSpacingProblems) {
  EXPECT_EQ(EstimateNoise(std::vector<double>(9, 1.0)).verdict,
            NoiseVerdict::kSpacingTooSmall);
  std::vector<double> steep;
  for (int i = 0; i < 9; ++i) steep.push_back(1.0 + i);
  EXPECT_EQ(EstimateNoise(steep).verdict, NoiseVerdict::kSpacingTooLarge);
}

TEST(KrigingTest, InterpolatesAndReproducesItsRegressionTrend) {
  std::vector<Eigen::Vector2d> x;
  std::vector<double> y;
  const auto f = [](const Eigen::Vector2d& u) {
    return 1 + 2 * u(0) - u(1) + 3 * u(0) * u(0) + u(0) * u(1);
  };
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> uniform(0, 1);
  for (int i = 0; i < 15; ++i) {
    x.emplace_back(uniform(rng), uniform(rng));
    y.push_back(f(x.back()));
  }
  KrigingModel model;
  ASSERT_TRUE(model.Fit(x, y, KrigingOptions()).ok());
  for (size_t i = 0; i < x.size(); ++i) {
    double mse = 1;
    EXPECT_NEAR(model.Predict(x[i], &mse), y[i], 1e-6);
    EXPECT_LT(mse, 1e-6);
  }
  // A quadratic is the trend itself: exact away from the data too.
  EXPECT_NEAR(model.Predict({0.37, 0.81}), f({0.37, 0.81}), 1e-5);
  // Too few points for the quadratic trend: a clear error.
  KrigingModel small;
  EXPECT_FALSE(small
                   .Fit({x.begin(), x.begin() + 5}, {y.begin(), y.begin() + 5},
                        KrigingOptions())
                   .ok());
  // Expected improvement: zero when certain and not better, positive when
  // uncertain.
  EXPECT_EQ(ExpectedImprovement(0.0, 1.0, 0.0), 0.0);
  EXPECT_GT(ExpectedImprovement(0.0, 1.0, 1.0), 0.0);
}

// A design step with a prior, then its surface from the same step options:
// on the grid the grid search laid out, and at its optimum, the surface
// holds exactly the values the optimizer recorded; design.json reads back
// what was written.
TEST(CriterionSurfaceTest, IsTheObjectiveTheStepSearched) {
  KcrigConfig config = SourceConfig();
  config.experiment.duration = 0.5;
  DesignStepOptions step;
  step.names = kBushings;
  step.values = std::vector<double>(5, 4e6);
  Eigen::MatrixXd prior;
  ASSERT_TRUE(NominalEvaluator(config)->Information({0.3, -0.2}, &prior).ok());
  step.prior_information = prior;
  step.criterion = Criterion::kA;
  step.optimizer = "grid";
  step.optimizer_options.grid_phi_points = 3;
  step.optimizer_options.grid_z_points = 2;
  step.objective.budget = 7;
  DesignRun run;
  const Design start{config.experiment.phi, config.experiment.z_a};
  ASSERT_TRUE(DesignStep(config, step, start, &run).ok());
  ASSERT_EQ(run.record.size(), 7u);  // the start, then the 3 x 2 grid

  SurfaceOptions options;
  options.phi_points = 3;
  options.z_points = 2;
  options.points = {run.result.best};
  CriterionSurface surface;
  const Status status = ComputeCriterionSurface(
      config, step, {Criterion::kA, Criterion::kD}, options, &surface);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(surface.grid.size(), 2u);
  ASSERT_EQ(surface.grid[0].size(), 6u);
  for (int k = 0; k < 6; ++k) {
    EXPECT_EQ(surface.grid[0][k], run.record[k + 1].value) << k;
  }
  EXPECT_DOUBLE_EQ(surface.phi.front(), config.experiment.phi_bounds.lower);
  EXPECT_DOUBLE_EQ(surface.z_a.back(), config.experiment.z_a_bounds.upper);
  EXPECT_NEAR(surface.at_points[0][0], run.result.best_value,
              1e-12 * std::abs(run.result.best_value));
  // D from the same information matrices.
  EXPECT_NEAR(surface.grid[1][0],
              EvaluateCriterion(Criterion::kD, run.record[1].information).value,
              1e-12);

  const std::string path =
      (std::filesystem::temp_directory_path() /
       ("kcrig_designer_test_" + std::to_string(::getpid()) + ".json"))
          .string();
  std::ofstream(path) << DesignRunsToJson(Criterion::kA, {run});
  Criterion criterion = Criterion::kD;
  std::vector<DesignRun> read;
  const Status read_status = ReadDesign(path, &criterion, &read);
  std::filesystem::remove(path);
  ASSERT_TRUE(read_status.ok()) << read_status.message();
  EXPECT_EQ(criterion, Criterion::kA);
  ASSERT_EQ(read.size(), 1u);
  EXPECT_EQ(read[0].result.optimizer, "grid");
  EXPECT_EQ(read[0].result.best_value, run.result.best_value);
  EXPECT_NEAR(read[0].result.best.phi, run.result.best.phi, 1e-15);
  EXPECT_EQ(read[0].result.best.z_a, run.result.best.z_a);
  EXPECT_EQ(read[0].result.evaluations, run.result.evaluations);
  ASSERT_EQ(read[0].record.size(), run.record.size());
  EXPECT_EQ(read[0].record.back().value, run.record.back().value);
  EXPECT_EQ(read[0].record.back().batch, run.record.back().batch);

  std::ofstream(path) << "{\"criterion\": \"A\", \"runs\": [{}]}";
  const Status broken = ReadDesign(path, &criterion, &read);
  std::filesystem::remove(path);
  ASSERT_FALSE(broken.ok());
  EXPECT_NE(broken.message().find(path + ": runs[0]: missing field"),
            std::string::npos)
      << broken.message();
}

}  // namespace
}  // namespace kcrig
