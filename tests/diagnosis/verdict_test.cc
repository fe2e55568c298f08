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
  StateVerdict(nullptr, rules, &none);
  EXPECT_EQ(none.verdict, "unexplained");
  EXPECT_TRUE(none.ambiguous_a.empty());
  EXPECT_NE(none.reason.find("no candidate closes 80 %"), std::string::npos);
}

}  // namespace
}  // namespace kcrig
