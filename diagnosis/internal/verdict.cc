#include "diagnosis/internal/verdict.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>

#include "diagnosis/internal/residual_statistics.h"

namespace kcrig {

bool VerdictRules::ClearlyBetter(const CandidateScore& best,
                                 const CandidateScore& other) const {
  if (!other.ok || other.at_far_bound) return true;
  const bool closes_more =
      best.gap_closed - other.gap_closed >= min_gap_margin ||
      other.score - 1 >= 3 * std::max(best.score - 1, score_noise);
  return closes_more && other.bic - best.bic >= min_bic_difference;
}

bool VerdictRules::Decides(const std::vector<CandidateScore>& ranked) const {
  if (ranked.empty() || !ranked[0].ok || ranked[0].at_far_bound) return false;
  if (!Explains(ranked[0])) return false;
  return ranked.size() < 2 || ClearlyBetter(ranked[0], ranked[1]);
}

bool VerdictRules::Explains(const CandidateScore& s) const {
  return s.gap_closed >= min_gap_closed || (holdout && AtNoise(s));
}

bool VerdictRules::AtNoise(const CandidateScore& s) const {
  const double p =
      !holdout ? ChiSquareUpperTail(s.train_chi2,
                                    training_residuals - s.num_parameters)
               : ChiSquareUpperTail(s.score * scored_residuals,
                                    static_cast<double>(scored_residuals));
  return p >= significance && s.ljung_box_p >= significance;
}

double VerdictRules::Separation(const CandidateScore& chosen,
                                const CandidateScore& rival) const {
  return std::max(0.0, rival.score - 1) /
         std::max(chosen.score - 1, score_noise);
}

namespace {

// A model's parts: "a@x+b" -> a@x, b.
std::vector<std::string> ModelParts(const std::string& model) {
  std::vector<std::string> parts;
  for (size_t begin = 0; begin <= model.size();) {
    const size_t end = std::min(model.find('+', begin), model.size());
    parts.push_back(model.substr(begin, end - begin));
    begin = end + 1;
  }
  return parts;
}

}  // namespace

std::vector<std::string> FaultClasses(const std::string& model) {
  std::vector<std::string> classes;
  for (const std::string& part : ModelParts(model)) {
    const std::string effect = part.substr(0, part.find('@'));
    classes.push_back(effect == "model_parameter" ? part : effect);
  }
  return classes;
}

VerdictRules MakeVerdictRules(const DiagnosisOptions& options, bool holdout,
                              int training_residuals, long scored_residuals) {
  VerdictRules rules;
  rules.min_gap_closed = options.min_gap_closed;
  rules.min_gap_margin = options.min_gap_margin;
  rules.min_bic_difference = options.min_bic_difference;
  rules.significance = options.significance;
  rules.high_confidence_gap_closed = options.high_confidence_gap_closed;
  rules.high_confidence_separation = options.high_confidence_separation;
  rules.score_noise = 5 * std::sqrt(2.0 / scored_residuals);
  rules.holdout = holdout;
  rules.training_residuals = training_residuals;
  rules.scored_residuals = scored_residuals;
  return rules;
}

void RankCandidates(std::vector<CandidateScore>* list) {
  std::stable_sort(list->begin(), list->end(),
                   [](const CandidateScore& a, const CandidateScore& b) {
                     if (a.ok != b.ok) return a.ok;
                     // A fit on a far bound stands in for another effect.
                     if (a.at_far_bound != b.at_far_bound) {
                       return !a.at_far_bound;
                     }
                     if (a.score != b.score) return a.score < b.score;
                     return a.bic < b.bic;
                   });
}

namespace {

// The verdict of `model`: its classes joined by '+', and the components it
// acts on.
void SetVerdictModel(const std::string& model, DiagnosisResult* result) {
  result->model = model;
  result->verdict.clear();
  std::vector<std::string> effects, targets;
  std::vector<BushingSet> places;
  if (!ParseModelName(model, &effects, &places, &targets).ok()) {
    result->verdict = model;  // a name the diagnosis made parses
    result->components.clear();
    return;
  }
  for (size_t e = 0; e < effects.size(); ++e) {
    // Two freed parameters are one class.
    if (std::find(effects.begin(), effects.begin() + e, effects[e]) ==
        effects.begin() + e) {
      result->verdict += (result->verdict.empty() ? "" : "+") + effects[e];
    }
  }
  result->components = ModelComponents(model);
}

}  // namespace

std::vector<HardPointMove> HardPointMoves(const CandidateScore& chosen) {
  std::vector<std::string> effects, targets;
  std::vector<BushingSet> places;
  std::vector<HardPointMove> moves;
  if (!ParseModelName(chosen.model, &effects, &places, &targets).ok()) {
    return moves;
  }
  const EstimationResult& fit = chosen.fit.result;
  for (size_t e = 0; e < effects.size(); ++e) {
    if (effects[e] != kModelParameter || !IsHardPoint(targets[e])) continue;
    std::array<int, 3> at{-1, -1, -1};
    for (int i = 0; i < static_cast<int>(fit.parameters.size()); ++i) {
      for (int k = 0; k < 3; ++k) {
        if (fit.parameters[i].name ==
            std::string(kModelParameter) + "." + targets[e] + "." + "xyz"[k]) {
          at[k] = i;
        }
      }
    }
    if (std::count(at.begin(), at.end(), -1) > 0) continue;
    HardPointMove move;
    move.point = targets[e];
    move.bounded = true;
    for (int k = 0; k < 3; ++k) {
      move.at_bound = move.at_bound || fit.parameters[at[k]].at_bound;
    }
    // The intervals' own scale (the widening and the discretisation bias
    // in them) with the fit's correlations.
    Eigen::Vector3d scale;
    for (int k = 0; k < 3; ++k) {
      const ParameterEstimate& p = fit.parameters[at[k]];
      move.configured(k) = p.initial;
      move.displacement(k) = p.value - p.initial;
      scale(k) = (p.ci95_high - p.ci95_low) / 2 / kZ95;
      move.bounded = move.bounded && std::isfinite(scale(k));
    }
    for (int j = 0; j < 3; ++j) {
      for (int k = 0; k < 3; ++k) {
        const double rho = fit.correlation.rows() > std::max(at[j], at[k])
                               ? fit.correlation(at[j], at[k])
                               : (j == k ? 1.0 : 0.0);
        move.covariance(j, k) = scale(j) * scale(k) * rho;
      }
    }
    moves.push_back(move);
  }
  return moves;
}

namespace {

// "hard point O1 sits 2.24 mm from its configured place: 1.75 mm further
// forward, 1.39 mm further left, 0.02 mm lower (95 % region +-0.11, +-0.09,
// +-0.8 mm along x, y, z); ".
std::string DescribeHardPointMove(const HardPointMove& move) {
  static const char* kMore[] = {"further forward", "further left", "higher"};
  static const char* kLess[] = {"further back", "further right", "lower"};
  std::string text = "hard point " + move.point;
  char part[160];
  std::snprintf(part, sizeof(part), " sits %.2f mm from its configured place: ",
                1e3 * move.displacement.norm());
  text += part;
  for (int k = 0; k < 3; ++k) {
    const double d = move.displacement(k);
    std::snprintf(part, sizeof(part), "%.2f mm %s%s", 1e3 * std::abs(d),
                  d > 0 ? kMore[k] : kLess[k], k < 2 ? ", " : "");
    text += part;
  }
  if (move.at_bound) text += " (at the bound of its range)";
  if (!move.bounded) return text + " (not every coordinate determined); ";
  // The 95 % region's extent along each axis.
  Eigen::Vector3d half;
  for (int k = 0; k < 3; ++k) {
    half(k) = 1e3 * std::sqrt(kHardPointRegion95 * move.covariance(k, k));
  }
  std::snprintf(part, sizeof(part),
                " (95 %% region +-%.2g, +-%.2g, +-%.2g mm along x, y, z); ",
                half(0), half(1), half(2));
  return text + part;
}

}  // namespace

std::string DescribeFreedParameters(const CandidateScore& chosen) {
  const std::string prefix = kModelParameter + std::string(".");
  std::string text;
  const std::vector<HardPointMove> moves = HardPointMoves(chosen);
  for (const HardPointMove& move : moves) text += DescribeHardPointMove(move);
  char line[240];
  for (const ParameterEstimate& p : chosen.fit.result.parameters) {
    if (p.name.rfind(prefix, 0) != 0) continue;
    const std::string name = p.name.substr(prefix.size());
    const std::string point = name.substr(0, name.find('.'));
    if (std::any_of(moves.begin(), moves.end(),
                    [&](const HardPointMove& m) { return m.point == point; })) {
      continue;
    }
    // A freed parameter's fit starts at its configured value.
    const double configured = p.initial;
    const double interval = 1.96 * p.standard_error;
    const char* bound = p.at_bound ? " (at the bound of its range)" : "";
    const size_t dot = name.find('.');
    if (dot == std::string::npos) {
      // Enough digits that the value is not rounded by more than its
      // interval.
      const int digits = std::clamp(
          2 + static_cast<int>(std::ceil(
                  std::log10(std::abs(p.value) / std::max(interval, 1e-300)))),
          3, 10);
      std::snprintf(line, sizeof(line),
                    "%s is %.*g +- %.2g %s%s, not the configured %.4g; ",
                    name.c_str(), digits, p.value, interval, p.unit.c_str(),
                    bound, configured);
    } else {
      const char axis = name[dot + 1];
      const bool more = p.value > configured;
      const char* where =
          axis == 'x'   ? (more ? "further forward" : "further back")
          : axis == 'y' ? (more ? "further left" : "further right")
                        : (more ? "higher" : "lower");
      std::snprintf(line, sizeof(line),
                    "hard point %s sits %.2f +- %.2g mm %s than configured%s "
                    "(%s %.4f m, not %.4f); ",
                    name.substr(0, dot).c_str(),
                    1e3 * std::abs(p.value - configured), 1e3 * interval, where,
                    bound, name.c_str(), p.value, configured);
    }
    text += line;
  }
  return text;
}

namespace {

// The best-scored candidate that names none of `chosen`'s faults.
void FindRival(const CandidateScore& chosen, const VerdictRules& rules,
               DiagnosisResult* result) {
  const std::vector<std::string> own = FaultClasses(chosen.model);
  for (const CandidateScore& s : result->ranking) {
    if (!s.ok || !s.scored || s.at_far_bound) continue;
    bool shares = false;
    for (const std::string& c : FaultClasses(s.model)) {
      shares |= std::find(own.begin(), own.end(), c) != own.end();
    }
    if (shares) continue;
    result->rival = s.model;
    result->rival_separation = rules.Separation(chosen, s);
    return;
  }
}

// Whether `model`'s effects include all of `other`'s and more
// ("a+b" over "a").
bool Extends(const std::string& model, const std::string& other) {
  const std::vector<std::string> own = ModelParts(model);
  const std::vector<std::string> theirs = ModelParts(other);
  return own.size() > theirs.size() &&
         std::all_of(theirs.begin(), theirs.end(), [&](const std::string& t) {
           return std::find(own.begin(), own.end(), t) != own.end();
         });
}

// Why the confidence is what it is, and for a low one what would raise it.
std::string ConfidenceText(bool at_noise, bool apart,
                           const DiagnosisResult& r) {
  if (at_noise) return "what is left is noise";
  char text[240];
  if (apart) {
    std::snprintf(text, sizeof(text),
                  "structure is left beyond the noise (the rig's form of the "
                  "effect is not quite the model's), but the best other "
                  "fault, %s, leaves %.0fx as much",
                  r.rival.c_str(), r.rival_separation);
  } else if (!r.rival.empty()) {
    std::snprintf(text, sizeof(text),
                  "some structure is left beyond the noise and %s leaves "
                  "only %.1fx as much: an experiment that tells them apart "
                  "would raise the confidence",
                  r.rival.c_str(), r.rival_separation);
  } else {
    return "some structure is left beyond the noise";
  }
  return text;
}

}  // namespace

std::vector<const CandidateScore*> Contenders(
    const std::vector<CandidateScore>& ranking, const VerdictRules& rules) {
  std::vector<const CandidateScore*> contenders;
  for (const CandidateScore& s : ranking) {
    const bool redundant =
        s.at_far_bound ||
        std::any_of(ranking.begin(), ranking.end(), [&](const auto& smaller) {
          return smaller.ok && Extends(s.model, smaller.model) &&
                 !rules.ClearlyBetter(s, smaller);
        });
    if (!redundant) contenders.push_back(&s);
  }
  // Never empty: a ranking of one stays itself.
  if (contenders.empty() && !ranking.empty()) {
    contenders.push_back(&ranking.front());
  }
  return contenders;
}

void StateVerdict(const CandidateScore* chosen, const VerdictRules& rules,
                  DiagnosisResult* result) {
  char text[400];
  result->rival.clear();
  result->rival_separation = 0;
  if (chosen != nullptr) {
    SetVerdictModel(chosen->model, result);
    result->hard_points = HardPointMoves(*chosen);
    FindRival(*chosen, rules, result);
    const bool at_noise = rules.AtNoise(*chosen);
    const bool apart =
        chosen->gap_closed >= rules.high_confidence_gap_closed &&
        result->rival_separation >= rules.high_confidence_separation;
    result->confidence = at_noise || apart ? "high" : "low";
    result->leaves_noise = at_noise;
    std::snprintf(text, sizeof(text),
                  "%s closes %.0f %% of the gap (score %.3g -> %.3g, noise "
                  "floor 1); %s",
                  chosen->model.c_str(), 100 * chosen->gap_closed,
                  result->nominal.score, chosen->score,
                  ConfidenceText(at_noise, apart, *result).c_str());
    result->reason = DescribeFreedParameters(*chosen) + text;
    return;
  }
  result->verdict = "unexplained";
  result->model.clear();
  result->components.clear();
  result->hard_points.clear();
  result->leaves_noise = false;
  const std::vector<const CandidateScore*> contenders =
      Contenders(result->ranking, rules);
  const CandidateScore& best = *contenders.front();
  const CandidateScore* second =
      contenders.size() > 1 ? contenders[1] : nullptr;
  std::string alternatives;
  if (rules.Explains(best) && second != nullptr && rules.Explains(*second)) {
    result->ambiguous_a = best.model;
    result->ambiguous_b = second->model;
    std::snprintf(text, sizeof(text),
                  "%s and %s both explain the data (%.0f %% and %.0f %% of "
                  "the gap closed): an experiment that tells them apart is "
                  "needed",
                  best.model.c_str(), second->model.c_str(),
                  100 * best.gap_closed, 100 * second->gap_closed);
    // Two alternatives that free parameters: what each says of them.
    alternatives =
        DescribeFreedParameters(best) + DescribeFreedParameters(*second);
  } else if (best.gap_closed >= rules.min_gap_closed && second != nullptr) {
    std::snprintf(text, sizeof(text),
                  "%s closes %.0f %% of the gap but is not clearly better "
                  "than %s (%.0f %%); see the localisation",
                  best.model.c_str(), 100 * best.gap_closed,
                  second->model.c_str(), 100 * second->gap_closed);
  } else {
    std::snprintf(text, sizeof(text),
                  "no candidate closes %.0f %% of the gap (best: %s, "
                  "%.0f %%); see the localisation",
                  100 * rules.min_gap_closed, best.model.c_str(),
                  100 * best.gap_closed);
  }
  result->reason = text;
  if (!alternatives.empty()) {
    result->reason +=
        "; either " + alternatives.substr(0, alternatives.size() - 2);
  }
}

}  // namespace kcrig
