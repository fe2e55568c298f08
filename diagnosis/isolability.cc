#include "diagnosis/isolability.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <limits>

#include "Eigen/QR"
#include "base/json_writer.h"
#include "base/parallel_for.h"
#include "estimator/effect_model.h"
#include "nlohmann/json.hpp"
#include "rt_core/model/plant_effects.h"

namespace kcrig {
namespace {

using Block = IsolabilityAnalysis::Block;

// Each candidate's model and the columns its effect parameters take after
// the stiffnesses' kNumBushings.
Status CreateModels(const SuspensionParameters<double>& nominal,
                    const std::vector<std::string>& candidates,
                    std::vector<EffectModel>* models,
                    std::vector<Block>* blocks) {
  const EstimatorOptions bounds;
  int column = kNumBushings;
  models->resize(candidates.size());
  for (size_t i = 0; i < candidates.size(); ++i) {
    KCRIG_RETURN_IF_ERROR(
        EffectModel::CreateNamed(nominal, candidates[i], bounds.lower_scale,
                                 bounds.upper_scale, &(*models)[i]));
    const int count = (*models)[i].num_parameters() - kNumBushings;
    if (count <= 0) {
      return Status::Error("isolability: " + candidates[i] +
                           " frees nothing to tell apart");
    }
    blocks->push_back({column, count});
    column += count;
  }
  return Status::Ok();
}

std::vector<double> StartOf(const EffectModel& model) {
  std::vector<double> values;
  for (const EffectParameter& p : model.parameters()) {
    values.push_back(p.initial);
  }
  return values;
}

// The weighted Jacobian of one experiment: the nominal model's stiffness
// columns, then each candidate's effect columns at the start of its fit.
Status ExperimentColumns(const EffectModel& nominal_model,
                         const std::vector<EffectModel>& models,
                         const std::vector<Block>& blocks, const Experiment& e,
                         double step, int num_threads,
                         ProgressReporter* progress, Eigen::MatrixXd* columns) {
  std::vector<double> theta;
  Eigen::MatrixXd jacobian;
  Eigen::VectorXd residuals;
  KCRIG_RETURN_IF_ERROR(WeightedJacobian(nominal_model, StartOf(nominal_model),
                                         {e}, step, &theta, &jacobian,
                                         &residuals));
  const int total =
      blocks.empty() ? kNumBushings : blocks.back().first + blocks.back().count;
  columns->resize(jacobian.rows(), total);
  columns->leftCols<kNumBushings>() = jacobian;
  const int n = static_cast<int>(models.size());
  const std::vector<Experiment> one = {e};
  std::vector<Status> status(n, Status::Ok());
  std::atomic<int> done{0};
  ParallelFor(n, num_threads, [&](int i) {
    if (progress->aborted()) return;
    std::vector<double> own_theta;
    Eigen::MatrixXd own;
    Eigen::VectorXd own_residuals;
    status[i] = WeightedJacobian(models[i], StartOf(models[i]), one, step,
                                 &own_theta, &own, &own_residuals);
    if (status[i].ok()) {
      columns->middleCols(blocks[i].first, blocks[i].count) =
          own.rightCols(blocks[i].count);
    }
    const int finished = ++done;
    progress->Report({"isolability on " + e.source + ": " +
                          std::to_string(finished) + "/" + std::to_string(n) +
                          " candidates",
                      static_cast<double>(finished) / n, finished, n});
  });
  // Stopped: the columns of the candidates skipped were never written.
  if (progress->aborted()) return Interrupted("isolability");
  for (const Status& s : status) KCRIG_RETURN_IF_ERROR(s);
  if (!columns->allFinite()) {
    return Status::Error(e.source +
                         ": a candidate's sensitivities are not finite");
  }
  return Status::Ok();
}

// The R factor of [r; rows]: the stacked Jacobian's triangle, one
// experiment at a time (the rows of a whole plan need not be held at once).
Eigen::MatrixXd StackTriangle(const Eigen::MatrixXd& r,
                              const Eigen::MatrixXd& rows) {
  Eigen::MatrixXd stacked(r.rows() + rows.rows(), rows.cols());
  stacked << r, rows;
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(stacked);
  const long k = std::min<long>(stacked.rows(), stacked.cols());
  return qr.matrixQR().topRows(k).triangularView<Eigen::Upper>();
}

// An orthonormal basis of the span of `a`'s columns (numerical rank).
Eigen::MatrixXd Basis(const Eigen::MatrixXd& a) {
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(a);
  qr.setThreshold(1e-9);
  const Eigen::MatrixXd q =
      qr.householderQ() * Eigen::MatrixXd::Identity(a.rows(), a.cols());
  return q.leftCols(qr.rank());
}

Eigen::MatrixXd ProjectOff(const Eigen::MatrixXd& basis,
                           const Eigen::MatrixXd& a) {
  return a - basis * (basis.transpose() * a);
}

// left(i, j) from the triangle: every signature off the stiffnesses, then
// what each rival's span leaves of it.
void FillMatrix(const Eigen::MatrixXd& r, const std::vector<Block>& blocks,
                Isolability* out) {
  const int n = static_cast<int>(blocks.size());
  const Eigen::MatrixXd stiffness = Basis(r.leftCols<kNumBushings>());
  std::vector<Eigen::MatrixXd> signature(n), span(n);
  for (int i = 0; i < n; ++i) {
    const Eigen::MatrixXd own = r.middleCols(blocks[i].first, blocks[i].count);
    signature[i] = ProjectOff(stiffness, own);
    // Invisible: nothing of it survives the stiffnesses (an axis no
    // experiment loads gives zero columns).
    out->visible[i] = signature[i].squaredNorm() >
                      1e-12 * std::max(own.squaredNorm(), 1e-300);
    if (out->visible[i]) span[i] = Basis(signature[i]);
  }
  // Undefined (NaN) where either is not seen: an unseen rival's residue
  // spans noise.
  out->left.setConstant(n, n, std::numeric_limits<double>::quiet_NaN());
  for (int i = 0; i < n; ++i) {
    if (!out->visible[i]) continue;
    const double whole = signature[i].squaredNorm();
    for (int j = 0; j < n; ++j) {
      if (!out->visible[j]) continue;
      out->left(i, j) =
          i == j ? 0.0
                 : ProjectOff(span[j], signature[i]).squaredNorm() / whole;
    }
  }
}

}  // namespace

bool Isolability::Separable(int i, int j) const {
  if (!visible[i] || !visible[j]) return false;
  return left(i, j) >= min_share_left && left(j, i) >= min_share_left;
}

std::vector<std::pair<int, int>> Isolability::Ties() const {
  std::vector<std::pair<int, int>> ties;
  const int n = static_cast<int>(candidates.size());
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      if (visible[i] && visible[j] && !Separable(i, j)) ties.push_back({i, j});
    }
  }
  return ties;
}

double Isolability::SmallestSeparation() const {
  double smallest = 1;
  const int n = static_cast<int>(candidates.size());
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      if (visible[i] && visible[j]) {
        smallest = std::min({smallest, left(i, j), left(j, i)});
      }
    }
  }
  return smallest;
}

std::vector<std::string> IsolabilityCandidates(
    const SuspensionParameters<double>& nominal) {
  std::vector<std::string> names;
  for (std::string_view effect : kEffectNames) {
    for (const std::string& c : PlaceableComponents(effect)) {
      names.push_back(std::string(effect) + "@" + c);
    }
  }
  const EstimatorOptions bounds;
  for (const std::string& p : FreeableModelParameters()) {
    EffectModel model;
    // A rate configured zero cannot be freed: no candidate.
    if (EffectModel::Create(nominal, {FreedModelName(p)}, bounds.lower_scale,
                            bounds.upper_scale, &model)
            .ok() &&
        model.num_parameters() > kNumBushings) {
      names.push_back(FreedModelName(p));
    }
  }
  return names;
}

Status IsolabilityAnalysis::Create(const SuspensionParameters<double>& nominal,
                                   double integrator_step,
                                   const IsolabilityOptions& options,
                                   IsolabilityAnalysis* analysis) {
  if (!(options.min_share_left > 0 && options.min_share_left < 1)) {
    return Status::Error("isolability: min_share_left must lie in (0, 1)");
  }
  IsolabilityAnalysis out;
  out.candidates_ = options.candidates.empty() ? IsolabilityCandidates(nominal)
                                               : options.candidates;
  out.options_ = options;
  out.step_ = integrator_step;
  KCRIG_RETURN_IF_ERROR(
      CreateModels(nominal, out.candidates_, &out.models_, &out.blocks_));
  const EstimatorOptions bounds;
  KCRIG_RETURN_IF_ERROR(EffectModel::Create(nominal, {}, bounds.lower_scale,
                                            bounds.upper_scale,
                                            &out.nominal_model_));
  out.triangle_.resize(0, out.blocks_.back().first + out.blocks_.back().count);
  *analysis = std::move(out);
  return Status::Ok();
}

Status IsolabilityAnalysis::Add(const Experiment& experiment) {
  ProgressReporter progress(options_.callback);
  Eigen::MatrixXd columns;
  KCRIG_RETURN_IF_ERROR(
      ExperimentColumns(nominal_model_, models_, blocks_, experiment, step_,
                        options_.num_threads, &progress, &columns));
  if (progress.aborted()) return Interrupted("isolability");
  triangle_ = StackTriangle(triangle_, columns);
  ++num_experiments_;
  return Status::Ok();
}

Isolability IsolabilityAnalysis::Matrix() const {
  Isolability out;
  out.candidates = candidates_;
  out.min_share_left = options_.min_share_left;
  out.visible.assign(candidates_.size(), false);
  FillMatrix(triangle_, blocks_, &out);
  return out;
}

Status ComputeIsolability(const SuspensionParameters<double>& nominal,
                          const std::vector<Experiment>& experiments,
                          double integrator_step,
                          const IsolabilityOptions& options,
                          Isolability* isolability) {
  *isolability = Isolability();
  if (experiments.empty()) {
    return Status::Error("isolability: no experiment to judge");
  }
  IsolabilityAnalysis analysis;
  KCRIG_RETURN_IF_ERROR(IsolabilityAnalysis::Create(nominal, integrator_step,
                                                    options, &analysis));
  for (const Experiment& e : experiments) {
    KCRIG_RETURN_IF_ERROR(analysis.Add(e));
  }
  *isolability = analysis.Matrix();
  return Status::Ok();
}

std::string IsolabilityToJson(const Isolability& iso) {
  using Json = nlohmann::ordered_json;
  Json left = Json::array();
  for (int i = 0; i < iso.left.rows(); ++i) {
    Json row = Json::array();
    for (int j = 0; j < iso.left.cols(); ++j) {
      const double v = iso.left(i, j);
      row.push_back(FiniteOrNull(v));
    }
    left.push_back(row);
  }
  Json ties = Json::array();
  for (const auto& [i, j] : iso.Ties()) {
    ties.push_back({iso.candidates[i], iso.candidates[j]});
  }
  std::vector<bool> visible = iso.visible;
  const Json doc = {{"candidates", iso.candidates},
                    {"visible", visible},
                    {"left", left},
                    {"min_share_left", iso.min_share_left},
                    {"ties", ties},
                    {"smallest_separation", iso.SmallestSeparation()}};
  return doc.dump();
}

std::string IsolabilitySummary(const Isolability& iso) {
  const int n = static_cast<int>(iso.candidates.size());
  int visible = 0;
  for (int i = 0; i < n; ++i) visible += iso.visible[i] ? 1 : 0;
  const auto ties = iso.Ties();
  const long pairs = static_cast<long>(visible) * (visible - 1) / 2;
  char line[400];
  std::snprintf(line, sizeof(line),
                "%d candidates, %d seen by the experiments; %ld of %ld pairs "
                "told apart (each leaves >= %.0f %% of the other's "
                "signature)%s\n",
                n, visible, pairs - static_cast<long>(ties.size()), pairs,
                100 * iso.min_share_left,
                ties.empty() ? "" : "; the ties, with the smaller share left:");
  std::string text = line;
  // Each pair once, under its first candidate, with its separation.
  for (int i = 0; i < n; ++i) {
    std::string partners;
    for (const auto& [a, b] : ties) {
      if (a != i) continue;
      std::snprintf(line, sizeof(line), "%s%s (%.0f %%)",
                    partners.empty() ? "" : ", ", iso.candidates[b].c_str(),
                    100 * std::min(iso.left(a, b), iso.left(b, a)));
      partners += line;
    }
    if (!partners.empty()) {
      text += "  " + iso.candidates[i] + " ~ " + partners + "\n";
    }
  }
  std::string unseen;
  for (int i = 0; i < n; ++i) {
    if (!iso.visible[i]) unseen += " " + iso.candidates[i];
  }
  if (!unseen.empty())
    text += "  not seen by these experiments:" + unseen + "\n";
  return text;
}

}  // namespace kcrig
