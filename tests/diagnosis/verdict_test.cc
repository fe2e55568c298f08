// The verdict policy alone, on hand-made scores: when a candidate is
// clearly the best, when it leaves nothing but noise, what is said.
#include "diagnosis/internal/verdict.h"

#include "gtest/gtest.h"

namespace kcrig {
namespace {

CandidateScore Scored(const std::string& model, double score, double gap_closed,
                      double bic) {
  CandidateScore s;
  s.model = model;
  s.score = score;
  s.gap_closed = gap_closed;
  s.bic = bic;
  s.ljung_box_p = 0.5;
  s.scored = s.heldout = true;
  return s;
}

VerdictRules HoldoutRules() {
  DiagnosisOptions options;
  return MakeVerdictRules(options, /*holdout=*/true, 24000, 12000);
}

TEST(VerdictTest, ClearlyBetterNeedsTheGapMarginOrAThirdAndTheBic) {
  const VerdictRules rules = HoldoutRules();
  const CandidateScore best = Scored("hysteresis", 1.01, 0.99, 100);
  // 20 % more of the gap and a BIC 10 lower: clearly better.
  EXPECT_TRUE(rules.ClearlyBetter(best, Scored("a", 1.3, 0.79, 110)));
  // Closer than the margin, and leaving less than three times the best's
  // remaining gap (above the noise floor): not clearly better.
  EXPECT_FALSE(rules.ClearlyBetter(Scored("b", 1.2, 0.9, 100),
                                   Scored("c", 1.4, 0.8, 200)));
  // Leaves a third of the other's remaining gap: clearly better.
  EXPECT_TRUE(rules.ClearlyBetter(Scored("b", 1.1, 0.9, 100),
                                  Scored("c", 1.31, 0.8, 200)));
  // The BIC must prefer it by min_bic_difference.
  EXPECT_FALSE(rules.ClearlyBetter(best, Scored("d", 3.0, 0.1, 105)));
  // A failed fit is beaten by anything.
  CandidateScore failed = Scored("e", 0, 0, 0);
  failed.ok = false;
  EXPECT_TRUE(rules.ClearlyBetter(best, failed));
}

TEST(VerdictTest, DecidesOnlyWhenEnoughOfTheGapIsClosed) {
  const VerdictRules rules = HoldoutRules();
  EXPECT_FALSE(rules.Decides({}));
  EXPECT_FALSE(rules.Decides({Scored("a", 1.5, 0.79, 0)}));
  EXPECT_TRUE(rules.Decides({Scored("a", 1.01, 0.95, 0)}));
  EXPECT_FALSE(
      rules.Decides({Scored("a", 1.01, 0.95, 0), Scored("b", 1.02, 0.93, 5)}));
  // A hold-out that shows the gap only weakly (nominal 1.05 on 12 000
  // residuals): 72 % closed, but what is left is noise there.
  EXPECT_TRUE(rules.Decides(
      {Scored("a", 1.012, 0.72, 0), Scored("b", 1.05, 0.0, 700000)}));
  // Beyond the noise and short of the fraction: no verdict.
  EXPECT_FALSE(rules.Decides(
      {Scored("a", 1.06, 0.72, 0), Scored("b", 1.2, 0.0, 700000)}));
}

TEST(VerdictTest, AtNoiseNeedsTheChiSquareAndAWhiteResidual) {
  const VerdictRules rules = HoldoutRules();
  CandidateScore s = Scored("a", 1.0, 1.0, 0);
  EXPECT_TRUE(rules.AtNoise(s));
  // 12 000 residuals at a mean square of 1.1: far beyond the noise.
  s.score = 1.1;
  EXPECT_FALSE(rules.AtNoise(s));
  s.score = 1.0;
  s.ljung_box_p = 1e-6;
  EXPECT_FALSE(rules.AtNoise(s));
  // Without a hold-out the training chi-square is tested.
  DiagnosisOptions options;
  const VerdictRules cv = MakeVerdictRules(options, false, 24000, 24000);
  s.ljung_box_p = 0.5;
  s.num_parameters = 6;
  s.train_chi2 = 24000;
  EXPECT_TRUE(cv.AtNoise(s));
  s.train_chi2 = 26000;
  EXPECT_FALSE(cv.AtNoise(s));
}

TEST(VerdictTest, StatesTheChosenModelTheAmbiguityOrUnexplained) {
  const VerdictRules rules = HoldoutRules();
  DiagnosisResult result;
  result.nominal = Scored("nominal", 9.0, 0, 0);
  result.ranking = {Scored("hysteresis", 1.0, 1.0, 0),
                    Scored("bushing_damping", 1.05, 0.99, 50)};
  StateVerdict(&result.ranking[0], rules, &result);
  EXPECT_EQ(result.verdict, "hysteresis");
  EXPECT_EQ(result.confidence, "high");
  EXPECT_NE(result.reason.find("closes 100 % of the gap"), std::string::npos);

  DiagnosisResult ambiguous = result;
  StateVerdict(nullptr, rules, &ambiguous);
  EXPECT_EQ(ambiguous.verdict, "unexplained");
  EXPECT_EQ(ambiguous.ambiguous_a, "hysteresis");
  EXPECT_EQ(ambiguous.ambiguous_b, "bushing_damping");

  DiagnosisResult none = result;
  none.ranking[0].gap_closed = 0.5;
  none.ranking[0].score = 5.0;  // half the gap left, beyond the noise
  StateVerdict(nullptr, rules, &none);
  EXPECT_EQ(none.verdict, "unexplained");
  EXPECT_TRUE(none.ambiguous_a.empty());
  EXPECT_NE(none.reason.find("no candidate closes 80 %"), std::string::npos);
}

TEST(VerdictTest, FaultClassesNameEachEffectAndEachFreedParameter) {
  EXPECT_EQ(FaultClasses("hysteresis@bushing:V1+sensor_offset@sensor:x"),
            (std::vector<std::string>{"hysteresis", "sensor_offset"}));
  EXPECT_EQ(FaultClasses("model_parameter@k_spring+model_parameter@O1.z"),
            (std::vector<std::string>{"model_parameter@k_spring",
                                      "model_parameter@O1.z"}));
  EXPECT_EQ(FaultClasses("actuator_lag"),
            (std::vector<std::string>{"actuator_lag"}));
}

// An effect of another form than the candidate's leaves structure: high
// confidence only when the best other fault leaves ten times as much; a
// placement or a pair with the verdict's own effect is not a rival.
TEST(VerdictTest, ConfidenceIsHighWhenNoOtherFaultComesNear) {
  const VerdictRules rules = HoldoutRules();
  DiagnosisResult result;
  result.nominal = Scored("nominal", 12.0, 0, 0);
  CandidateScore chosen = Scored("bushing_damping@bushing:P", 1.3, 0.97, 0);
  chosen.ljung_box_p = 1e-100;
  result.ranking = {chosen, Scored("bushing_damping", 1.5, 0.95, 50),
                    Scored("hysteresis+bushing_damping", 1.6, 0.94, 60),
                    Scored("hysteresis@bushing:P", 4.3, 0.7, 900)};
  StateVerdict(&result.ranking[0], rules, &result);
  EXPECT_EQ(result.rival, "hysteresis@bushing:P");
  EXPECT_NEAR(result.rival_separation, 3.3 / 0.3, 1e-9);
  EXPECT_EQ(result.confidence, "high");
  EXPECT_NE(result.reason.find("leaves 11x as much"), std::string::npos)
      << result.reason;

  result.ranking[3].score = 2.0;  // the rival leaves 3.3x: low
  StateVerdict(&result.ranking[0], rules, &result);
  EXPECT_EQ(result.confidence, "low");
  EXPECT_NE(result.reason.find("an experiment that tells them apart"),
            std::string::npos)
      << result.reason;

  result.ranking[3].score = 4.3;  // far apart, but too little of the gap
  result.ranking[0].gap_closed = 0.85;
  StateVerdict(&result.ranking[0], rules, &result);
  EXPECT_EQ(result.confidence, "low");
}

// A freed parameter in words: the value to the digits its interval needs,
// a hard point's offset with its direction in the rig frame (ISO 8855: x
// forward, y left, z up), a value on its bound said so; the components.
TEST(VerdictTest, FreedParametersAreStatedAgainstTheirConfiguredValues) {
  auto freed = [](const char* name, double value, double configured,
                  double standard_error, bool at_bound) {
    ParameterEstimate p;
    p.name = name;
    p.unit = std::string(name).find('.', 16) != std::string::npos ? "m" : "N/m";
    p.value = value;
    p.initial = configured;
    p.standard_error = standard_error;
    p.at_bound = at_bound;
    return p;
  };
  CandidateScore s;
  s.fit.result.parameters = {
      freed("model_parameter.k_spring", 140370, 1.1e5, 13.8, false),
      freed("model_parameter.O1.z", 0.121, 0.117, 1e-4, false),
      freed("model_parameter.N2.y", 0.300, 0.305, 1e-4, false),
      freed("model_parameter.Q.x", 0.05, 0.10, 1e-4, true)};
  const std::string text = DescribeFreedParameters(s);
  EXPECT_NE(text.find("k_spring is 140370 +- 27 N/m, not the configured "
                      "1.1e+05"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("hard point O1 sits 4.00 +- 0.2 mm higher"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("hard point N2 sits 5.00 +- 0.2 mm further right"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("further back than configured (at the bound"),
            std::string::npos)
      << text;

  DiagnosisResult result;
  result.nominal = Scored("nominal", 9.0, 0, 0);
  result.ranking = {
      Scored("model_parameter@O1.z+model_parameter@k_spring", 1.0, 1.0, 0)};
  StateVerdict(&result.ranking[0], HoldoutRules(), &result);
  EXPECT_EQ(result.verdict, "model_parameter");
  EXPECT_EQ(result.components,
            (std::vector<std::string>{"hardpoint:O1", "strut:spring"}));
}

// A model that adds an effect the data do not need is the smaller model:
// the ambiguity is between explanations, not between a model and itself
// with an extra term; a pair clearly better than its part stays.
TEST(VerdictTest, AModelWithAnEffectTheDataDoNotNeedIsNoRival) {
  DiagnosisResult result;
  result.nominal = Scored("nominal", 9.0, 0, 0);
  result.ranking = {
      Scored("model_parameter@U1+sensor_offset", 1.0244, 0.997, 10),
      Scored("model_parameter@U1", 1.0244, 0.997, 0),
      Scored("model_parameter@U1+actuator_lag", 1.0261, 0.996, 12),
      Scored("model_parameter@V1", 1.0574, 0.992, 5),
      Scored("hysteresis+sensor_offset", 1.001, 0.999, -500),
      Scored("hysteresis", 1.9, 0.89, 0)};
  const std::vector<const CandidateScore*> contenders =
      Contenders(result.ranking, HoldoutRules());
  std::vector<std::string> names;
  for (const CandidateScore* s : contenders) names.push_back(s->model);
  EXPECT_EQ(names, (std::vector<std::string>{
                       "model_parameter@U1", "model_parameter@V1",
                       "hysteresis+sensor_offset", "hysteresis"}));
  result.ranking.erase(result.ranking.begin() + 4, result.ranking.end());
  StateVerdict(nullptr, HoldoutRules(), &result);
  EXPECT_EQ(result.ambiguous_a, "model_parameter@U1") << result.reason;
  EXPECT_EQ(result.ambiguous_b, "model_parameter@V1") << result.reason;
}

// A candidate whose effect needed more than its plausible range (a hard
// point on its 50 mm bound) compensates for another effect: it never
// decides and is no contender, however well it scores.
TEST(VerdictTest, ACandidateOnAFarBoundNeverDecides) {
  std::vector<CandidateScore> ranked = {
      Scored("rig_compliance+model_parameter@V2", 1.0, 1.0, 0),
      Scored("rig_compliance", 6.0, 0.55, 50000)};
  const VerdictRules rules = HoldoutRules();
  EXPECT_TRUE(rules.Decides(ranked));
  ranked[0].at_far_bound = true;
  EXPECT_FALSE(rules.Decides(ranked));
  const std::vector<const CandidateScore*> contenders =
      Contenders(ranked, rules);
  ASSERT_EQ(contenders.size(), 1u);
  EXPECT_EQ(contenders[0]->model, "rig_compliance");
  // It ranks after every fit within its range, and is no runner-up.
  RankCandidates(&ranked);
  EXPECT_EQ(ranked[0].model, "rig_compliance");
  ranked.insert(ranked.begin(),
                Scored("rig_compliance@fixture:x+fixture:rx", 1.0, 1.0, 0));
  EXPECT_TRUE(rules.Decides(ranked));
}

// Leaving only noise explains a gap on hold-out logs; under
// cross-validation (the training chi-square) it does not replace the
// fraction closed.
TEST(VerdictTest, OnlyNoiseLeftExplainsTheGapOnHoldoutLogs) {
  const CandidateScore s = Scored("a", 1.012, 0.72, 0);
  EXPECT_TRUE(HoldoutRules().Explains(s));
  DiagnosisOptions options;
  const VerdictRules cv = MakeVerdictRules(options, false, 24000, 24000);
  CandidateScore fitted = s;
  fitted.num_parameters = 6;
  fitted.train_chi2 = 24000;
  EXPECT_TRUE(cv.AtNoise(fitted));
  EXPECT_FALSE(cv.Explains(fitted));
}

// A hard point freed whole: one move in words (its length, each axis'
// direction, the 95 % region's extent), its covariance from the intervals'
// widths and the fit's correlations; on the verdict's model only.
TEST(VerdictTest, AHardPointFreedWholeIsStatedAsOneMoveWithItsRegion) {
  CandidateScore s = Scored("model_parameter@V1", 1.0, 1.0, 0);
  const double configured[3] = {0.224, 0.351, -0.078};
  const double move[3] = {0.00175, 0.00139, -0.0002};
  const double se[3] = {1e-4, 2e-4, 5e-4};
  for (int k = 0; k < 3; ++k) {
    ParameterEstimate p;
    p.name = std::string("model_parameter.V1.") + "xyz"[k];
    p.unit = "m";
    p.initial = configured[k];
    p.value = configured[k] + move[k];
    p.standard_error = se[k];
    p.ci95_low = p.value - kZ95 * se[k];
    p.ci95_high = p.value + kZ95 * se[k];
    s.fit.result.parameters.push_back(p);
  }
  s.fit.result.correlation = Eigen::Matrix3d::Identity();
  s.fit.result.correlation(0, 1) = s.fit.result.correlation(1, 0) = 0.5;
  const std::vector<HardPointMove> moves = HardPointMoves(s);
  ASSERT_EQ(moves.size(), 1u);
  EXPECT_EQ(moves[0].point, "V1");
  EXPECT_TRUE(moves[0].bounded);
  EXPECT_NEAR(moves[0].displacement(1), 0.00139, 1e-12);
  EXPECT_NEAR(moves[0].covariance(0, 1), 0.5 * 1e-4 * 2e-4, 1e-15);
  EXPECT_NEAR(moves[0].covariance(2, 2), 25e-8, 1e-15);
  const std::string text = DescribeFreedParameters(s);
  EXPECT_NE(text.find("hard point V1 sits 2.24 mm from its configured place: "
                      "1.75 mm further forward, 1.39 mm further left, 0.20 mm "
                      "lower (95 % region +-0.28, +-0.56, +-1.4 mm along x, "
                      "y, z)"),
            std::string::npos)
      << text;
  EXPECT_EQ(text.find("V1.x"), std::string::npos) << text;

  DiagnosisResult result;
  result.nominal = Scored("nominal", 9.0, 0, 0);
  result.ranking = {s};
  StateVerdict(&result.ranking[0], HoldoutRules(), &result);
  EXPECT_EQ(result.components, std::vector<std::string>{"hardpoint:V1"});
  ASSERT_EQ(result.hard_points.size(), 1u);
  result.ranking.push_back(Scored("model_parameter@U1", 1.0, 1.0, 0));
  StateVerdict(nullptr, HoldoutRules(), &result);
  EXPECT_TRUE(result.hard_points.empty());
}

}  // namespace
}  // namespace kcrig
