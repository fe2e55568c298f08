// The verdict policy of the diagnosis: when a scored candidate is clearly
// the best, when it leaves nothing but noise, and the sentence that says so.
// Apart from the fitting so that it can be tested on its own.
#ifndef KCRIG_DIAGNOSIS_INTERNAL_VERDICT_H_
#define KCRIG_DIAGNOSIS_INTERNAL_VERDICT_H_

#include <vector>

#include "diagnosis/diagnosis.h"

namespace kcrig {

struct VerdictRules {
  double min_gap_closed = 0.8;  // DiagnosisOptions
  double min_gap_margin = 0.2;
  double min_bic_difference = 10;
  double significance = 1e-3;
  double high_confidence_gap_closed = 0.9;
  double high_confidence_separation = 10;
  // Five standard deviations of a score at the noise floor.
  double score_noise = 0;
  // Whether the scores are on hold-out logs (else cross-validation or the
  // training chi-square), and the residual counts of training and scoring.
  bool holdout = false;
  int training_residuals = 0;
  long scored_residuals = 0;

  // `best` closes min_gap_margin more of the gap than `other`, or leaves a
  // third of the other's remaining gap (not less than score_noise), and the
  // BIC prefers it by min_bic_difference; always against a failed fit or
  // one on a far bound.
  bool ClearlyBetter(const CandidateScore& best,
                     const CandidateScore& other) const;
  // Whether `s` explains the gap: it closes min_gap_closed of it or, on
  // hold-out logs (a hold-out that shows the gap weakly measures the
  // fraction closed no better), leaves only noise there.
  bool Explains(const CandidateScore& s) const;
  // Whether ranked[0] explains the gap, did not stop on a far bound and is
  // clearly better than ranked[1].
  bool Decides(const std::vector<CandidateScore>& ranked) const;
  // Whether a model leaves nothing but noise on the data it was scored on:
  // the hold-out's chi-square, else (a cross-validation fold extrapolates
  // with a larger uncertainty) the full fit's training chi-square; and a
  // white residual there (a model that mimics an effect it does not contain
  // can reach the chi-square of the noise and leave a correlated residual).
  bool AtNoise(const CandidateScore& s) const;
  // How many times `chosen`'s remaining gap (not less than score_noise)
  // `rival` leaves.
  double Separation(const CandidateScore& chosen,
                    const CandidateScore& rival) const;
};

// The rules of `options` for `nominal` (scored) on `scored_residuals`.
VerdictRules MakeVerdictRules(const DiagnosisOptions& options, bool holdout,
                              int training_residuals, long scored_residuals);

// The faults a model names: its effects, each freed parameter on its own
// ("hysteresis@bushing:V1+sensor_offset" -> hysteresis, sensor_offset).
std::vector<std::string> FaultClasses(const std::string& model);

// Successful fits first, those on a far bound after the others, then by
// score, then by BIC.
void RankCandidates(std::vector<CandidateScore>* list);

// The ranking (in its order) without the models that add an effect to
// another candidate and are not clearly better than it (two models that
// differ by an effect the data do not need are one explanation, the
// smaller) and without those stopped on a far bound (at_far_bound).
std::vector<const CandidateScore*> Contenders(
    const std::vector<CandidateScore>& ranking, const VerdictRules& rules);

// Sets verdict, confidence, reason and the ambiguous pair of `result` from
// the chosen candidate (nullptr: none qualified) and the ranking's
// contenders (Contenders); the reason says what the chosen candidate's freed
// parameters, or each of an ambiguous pair's, would mean
// (DescribeFreedParameters).
void StateVerdict(const CandidateScore* chosen, const VerdictRules& rules,
                  DiagnosisResult* result);

// The hard points `chosen` frees whole (model_parameter@O1), each with the
// uncertainty of its move.
std::vector<HardPointMove> HardPointMoves(const CandidateScore& chosen);

// The model parameters `chosen` frees, in words against their configured
// values: "k_spring is 1.402e+05 +- 3.8e+03 N/m, not the configured
// 1.1e+05; ", "hard point O1 sits 4.00 +- 0.3 mm higher than configured
// (O1.z 0.2540 m, not 0.2500); " (+- the 95 % interval; one coordinate
// freed), "hard point O1 sits 2.24 mm from its configured place: 1.75 mm
// further forward, 1.39 mm further left, 0.02 mm lower (95 % region
// +-0.11, +-0.09, +-0.8 mm along x, y, z); " (a point freed whole); "" for
// none.
std::string DescribeFreedParameters(const CandidateScore& chosen);

}  // namespace kcrig

#endif  // KCRIG_DIAGNOSIS_INTERNAL_VERDICT_H_
