#include "designer/isolating_design.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>

#include "designer/internal/shape_search.h"
#include "nlohmann/json.hpp"
#include "rt_core/model/channels.h"

namespace kcrig {
namespace {

struct TieScore {
  double mean = 0;
  double smallest = 1;
  int separable = 0;
};

TieScore ScoreTies(const Isolability& iso,
                   const std::vector<std::pair<int, int>>& pairs) {
  TieScore score;
  for (const auto& [i, j] : pairs) {
    const double both = iso.visible[i] && iso.visible[j]
                            ? std::min(iso.left(i, j), iso.left(j, i))
                            : 0.0;
    score.mean += both / pairs.size();
    score.smallest = std::min(score.smallest, both);
    score.separable += iso.Separable(i, j) ? 1 : 0;
  }
  return score;
}

// The candidates of the plan's ties alone (a trial then computes only
// theirs), and the ties as pairs of their indices there.
IsolabilityOptions TiedCandidates(const Isolability& whole,
                                  const IsolabilityOptions& options,
                                  std::vector<std::pair<int, int>>* pairs,
                                  IsolatingDesign* design) {
  IsolabilityOptions tied = options;
  tied.candidates.clear();
  std::vector<int> index(whole.candidates.size(), -1);
  auto add = [&](int k) {
    if (index[k] < 0) {
      index[k] = static_cast<int>(tied.candidates.size());
      tied.candidates.push_back(whole.candidates[k]);
    }
    return index[k];
  };
  for (const auto& [i, j] : whole.Ties()) {
    pairs->push_back({add(i), add(j)});
    design->ties.push_back({whole.candidates[i], whole.candidates[j]});
  }
  return tied;
}

}  // namespace

Status DesignIsolatingExperiment(const KcrigConfig& config,
                                 const std::vector<Experiment>& plan,
                                 const IsolatingDesignOptions& options,
                                 IsolatingDesign* design) {
  *design = IsolatingDesign();
  const double step = config.experiment.step;
  // The caller's callback, watched: a stop ends the search at once.
  std::atomic<bool> stopped{false};
  IsolabilityOptions watched = options.isolability;
  watched.callback = [&stopped, outer = options.isolability.callback](
                         const IterationSummary& summary) {
    const CallbackReturn r = outer ? outer(summary) : CallbackReturn::kContinue;
    if (r == CallbackReturn::kAbort) stopped = true;
    return r;
  };
  Isolability whole;
  KCRIG_RETURN_IF_ERROR(
      ComputeIsolability(config.model, plan, step, watched, &whole));
  std::vector<std::pair<int, int>> pairs;
  const IsolabilityOptions tied =
      TiedCandidates(whole, watched, &pairs, design);
  if (pairs.empty()) return Status::Ok();
  IsolabilityAnalysis base;
  KCRIG_RETURN_IF_ERROR(
      IsolabilityAnalysis::Create(config.model, step, tied, &base));
  for (const Experiment& e : plan) KCRIG_RETURN_IF_ERROR(base.Add(e));
  const TieScore before = ScoreTies(base.Matrix(), pairs);
  // A trial ramp the models cannot be evaluated on is skipped; a stop
  // ends the search.
  Status failure = Status::Ok();
  auto with = [&](const RampExcitation<double>& ramp, TieScore* score) {
    IsolabilityAnalysis trial = base;
    Experiment e = PlannedExperiment(ramp, config.experiment);
    char name[80];
    std::snprintf(name, sizeof(name), "trial ramp phi %.1f deg, z_a %.3f m",
                  ramp.phi / kDegree, ramp.z_a);
    e.source = name;
    const Status status = trial.Add(e);
    if (!status.ok()) {
      failure = status;
      return false;
    }
    *score = ScoreTies(trial.Matrix(), pairs);
    return true;
  };
  const ShapeSearchResult found =
      MaximizeOverShapes(config.experiment, options.search.shapes,
                         options.search.evaluations_per_shape,
                         [&](const RampExcitation<double>& ramp) {
                           TieScore score;
                           if (stopped || !with(ramp, &score))
                             return std::nan("");
                           return score.mean;
                         });
  if (stopped) return Interrupted("isolating design");
  if (found.value < 0) {
    return failure.ok()
               ? Status::Error("isolating design: no design could be evaluated")
               : failure;
  }
  TieScore after;
  if (!with(found.best, &after)) return failure;
  design->excitation = found.best;
  design->evaluations = found.evaluations;
  design->mean_before = before.mean;
  design->smallest_before = before.smallest;
  design->mean_after = after.mean;
  design->smallest_after = after.smallest;
  design->resolved = after.separable - before.separable;
  return Status::Ok();
}

std::string IsolatingDesignToJson(const IsolatingDesign& design) {
  nlohmann::ordered_json ties = nlohmann::ordered_json::array();
  for (const auto& [a, b] : design.ties) ties.push_back({a, b});
  nlohmann::ordered_json doc = {{"ties", ties}};
  if (!design.ties.empty()) {
    const RampExcitation<double>& d = design.excitation;
    doc["criterion"] =
        "mean over the ties of min(left(i, j), left(j, i)) with the ramp";
    doc["phi_deg"] = d.phi / kDegree;
    doc["z_a_m"] = d.z_a;
    doc["fmax_n"] = d.fmax;
    doc["tf_s"] = d.duration;
    doc["hold_s"] = d.hold;
    doc["return_s"] = d.return_duration;
    doc["resolved"] = design.resolved;
    doc["mean_separation_before"] = design.mean_before;
    doc["mean_separation_after"] = design.mean_after;
    doc["smallest_separation_before"] = design.smallest_before;
    doc["smallest_separation_after"] = design.smallest_after;
    doc["evaluations"] = design.evaluations;
    doc["run_options"] = RunOptions(d);
  }
  return doc.dump(2) + "\n";
}

}  // namespace kcrig
