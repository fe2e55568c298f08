#include "diagnosis/diagnosis.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>

#include "base/batch_runner.h"
#include "diagnosis/internal/discrepancy.h"
#include "diagnosis/internal/fit_codec.h"
#include "diagnosis/internal/localisation.h"
#include "diagnosis/internal/residual_statistics.h"
#include "diagnosis/internal/verdict.h"

namespace kcrig {
namespace {

// The information criteria of a fit with chi-square `chi2`, k parameters
// and m residuals.
void InformationCriteria(double chi2, int k, int m, CandidateScore* s) {
  s->train_chi2 = chi2;
  s->num_parameters = k;
  s->bic = chi2 + k * std::log(static_cast<double>(m));
  s->aicc =
      chi2 + 2.0 * k + (m > k + 1 ? 2.0 * k * (k + 1) / (m - k - 1) : 0.0);
}

// One diagnosis in named stages over one state: check the inputs, fit the
// nominal model and test its gap, localise it, score the nominal model on
// the data the candidates will be scored on, fit and score the single
// effects and then pairs, place a bushing effect on its bushings, decide.
class DiagnosisRun {
 public:
  DiagnosisRun(const SuspensionParameters<double>& nominal,
               const std::vector<Experiment>& training,
               const std::vector<Experiment>& holdout,
               const DiagnosisOptions& options, double step,
               DiagnosisResult* result)
      : nominal_(nominal),
        training_(training),
        holdout_(holdout),
        options_(options),
        step_(step),
        result_(result),
        start_(std::chrono::steady_clock::now()),
        progress_(options.callback) {}

  // A stage that fails or returns early because the callback asked to stop
  // makes the diagnosis interrupted.
  Status Run() {
    *result_ = DiagnosisResult();
    const Status status = RunStages();
    return progress_.aborted() ? Interrupted("diagnosis") : status;
  }

 private:
  using Start = std::vector<double>;
  // A start computed when its round comes (ScaledStart).
  static inline const Start kScaledStart = {};

  Status RunStages() {
    KCRIG_RETURN_IF_ERROR(CheckInputs());
    KCRIG_RETURN_IF_ERROR(CreateModels());
    KCRIG_RETURN_IF_ERROR(Progress("nominal fit", 0));
    KCRIG_RETURN_IF_ERROR(FitNominal());
    KCRIG_RETURN_IF_ERROR(JoinHoldoutWhenMispredicted());
    KCRIG_RETURN_IF_ERROR(Progress("localisation and per-log fits", 0.1));
    Localize(training_, residuals_, options_, result_);
    EstimateDrift();
    if (progress_.aborted()) return Interrupted("diagnosis");
    result_->scoring = !holdout_.empty()      ? "holdout"
                       : training_.size() > 1 ? "cross_validation"
                                              : "information_criterion";
    if (!result_->gap) {
      result_->verdict = "none";
      result_->reason =
          "the nominal model's residual is consistent with the sensor noise "
          "(chi-square and Ljung-Box tests)";
      return Finish();
    }
    KCRIG_RETURN_IF_ERROR(ScoreWhereTheGapShows());
    KCRIG_RETURN_IF_ERROR(ProposeModelParameters());
    FitSingles();
    if (progress_.aborted()) return Interrupted("diagnosis");
    const CandidateScore* chosen = ChooseWithPairs();
    if (progress_.aborted()) return Interrupted("diagnosis");
    chosen = PlaceOnComponents(chosen);
    if (progress_.aborted()) return Interrupted("diagnosis");
    KCRIG_RETURN_IF_ERROR(RefineChosen(chosen));
    StateVerdict(chosen, rules_, result_);
    KCRIG_RETURN_IF_ERROR(CharacteriseWhenUnexplained());
    result_->reason = scoring_note_ + result_->reason;
    if (result_->gap_source == "prediction") {
      result_->reason = "fits the training logs, mispredicts the hold-out (" +
                        result_->prediction.reason +
                        "): an effect absorbed by biased stiffnesses; " +
                        result_->reason;
    }
    return Finish();
  }

  Status CheckInputs() const {
    if (training_.empty()) return Status::Error("diagnose: no training log");
    const std::vector<std::string>& names = options_.candidates;
    if (names.empty()) return Status::Error("diagnose: no candidate effect");
    for (size_t i = 0; i < names.size(); ++i) {
      if (std::find(names.begin(), names.begin() + i, names[i]) !=
          names.begin() + i) {
        return Status::Error("diagnose: candidate '" + names[i] +
                             "' given twice");
      }
    }
    if (options_.ljung_box_lags < 1 ||
        options_.min_samples < options_.ljung_box_lags + 20 ||
        options_.retry_pool < 0 || options_.num_threads < 1) {
      return Status::Error(
          "diagnose: options need ljung_box_lags >= 1, min_samples >= "
          "ljung_box_lags + 20, retry_pool >= 0 and num_threads >= 1");
    }
    KCRIG_RETURN_IF_ERROR(CheckSameForceChannels(training_, holdout_));
    for (const std::vector<Experiment>* set : {&training_, &holdout_}) {
      for (const Experiment& e : *set) {
        const int n = ObservedCount(e);
        if (n < options_.min_samples) {
          return Status::Error(
              e.source + ": " + std::to_string(n) +
              " observed samples; a diagnosis needs at least " +
              std::to_string(options_.min_samples) +
              " per log for its residual statistics (record a longer ramp)");
        }
      }
    }
    return Status::Ok();
  }

  Status CreateModels() {
    const double lower = options_.estimator.lower_scale;
    const double upper = options_.estimator.upper_scale;
    KCRIG_RETURN_IF_ERROR(
        EffectModel::Create(nominal_, {}, lower, upper, &nominal_model_));
    for (const std::string& name : options_.candidates) {
      EffectModel m;
      const Status status =
          EffectModel::Create(nominal_, {name}, lower, upper, &m);
      if (!status.ok()) return Status::Error("diagnose: " + status.message());
      singles_.push_back(std::move(m));
    }
    fit_options_ = options_.fit;
    fit_options_.uncertainty = options_.estimator;
    fit_options_.uncertainty.adequacy = AdequacyTests();
    fit_options_.callback = progress_.Nested();
    candidate_fit_options_ = fit_options_;
    candidate_fit_options_.function_tolerance = std::max(
        fit_options_.function_tolerance, options_.candidate_function_tolerance);
    return Status::Ok();
  }

  const BatchRunner& Batches() const { return BatchesOr(options_.batches); }

  // `count` fits as one batch (spread over the ranks with
  // options_.batches: each rank then has every fit, bit for bit).
  void RunFits(int count, const std::function<Status(int, EffectFit*)>& fit,
               std::vector<EffectFit>* fits,
               std::vector<Status>* status) const {
    std::vector<std::string> outcomes;
    Batches().Run(
        count, options_.num_threads,
        [&](int k, std::string* outcome) {
          EffectFit one;
          const Status s = fit(k, &one);
          *outcome = EncodeFit(s, one);
        },
        &outcomes);
    fits->assign(count, EffectFit());
    status->assign(count, Status::Ok());
    for (int k = 0; k < count; ++k) {
      if (!DecodeFit(outcomes[k], &(*status)[k], &(*fits)[k])) {
        (*status)[k] = Status::Error("a fit's result arrived corrupt");
      }
    }
  }

  // The fraction done is a rough guide from typical stage costs: the fits
  // of the single effects take about half of a diagnosis, pairs a quarter.
  Status Progress(const std::string& text, double fraction) {
    return progress_.Report({text, fraction}) ? Status::Ok()
                                              : Interrupted("diagnosis");
  }

  Status Finish() {
    result_->seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_)
            .count();
    return Status::Ok();
  }

  // Stage 1: the nominal fit on the training logs and its gap tests.
  Status FitNominal() {
    CandidateScore& nominal_score = result_->nominal;
    nominal_score.model = "nominal";
    KCRIG_RETURN_IF_ERROR(FitEffectModel(nominal_model_, training_, {},
                                         fit_options_, step_,
                                         &nominal_score.fit));
    KCRIG_RETURN_IF_ERROR(ModelResiduals(
        nominal_model_, nominal_score.fit.values, training_, &residuals_));
    const int n_nominal = nominal_model_.num_parameters();
    // A continuous rig is not the model's 1 ms scheme: the model's own
    // discretisation error must not pass for a gap.
    std::vector<std::vector<Vec6<double>>> error, limit = residuals_;
    KCRIG_RETURN_IF_ERROR(DiscretisationError(
        nominal_model_, nominal_score.fit.values, training_, step_, &error));
    for (size_t l = 0; l < limit.size(); ++l) {
      for (size_t j = 0; j < limit[l].size(); ++j) limit[l][j] -= error[l][j];
    }
    const Adequacy fit =
        BetterOfStepAndLimit(AssessAdequacy(training_, residuals_, kAllChannels,
                                            n_nominal, AdequacyTests()),
                             AssessAdequacy(training_, limit, kAllChannels,
                                            n_nominal, AdequacyTests()),
                             training_, error);
    result_->discretisation = fit.discretisation;
    result_->continuous_limit = fit.continuous_limit;
    m_ = static_cast<int>(fit.dof) + n_nominal;
    result_->chi2 = fit.chi_square;
    result_->dof = static_cast<int>(fit.dof);
    result_->chi2_p = fit.p_value;
    result_->ljung_box_p = fit.whiteness_p;
    result_->gap = !fit.adequate;
    if (result_->gap) result_->gap_source = "training";
    InformationCriteria(fit.chi_square, n_nominal, m_, &nominal_score);
    return Status::Ok();
  }

  // Stage 1b: a nominal fit that explains the training logs may still
  // mispredict the hold-out: an effect absorbed by biased stiffnesses. The
  // training logs alone cannot tell that effect from the stiffnesses, so
  // the hold-out joins them, the nominal model is refitted to all, and the
  // candidates are scored by cross-validation over the logs.
  Status JoinHoldoutWhenMispredicted() {
    if (result_->gap || holdout_.empty()) return Status::Ok();
    KCRIG_RETURN_IF_ERROR(
        PredictEffectModel(nominal_model_, result_->nominal.fit, holdout_,
                           step_, AdequacyTests(), &result_->prediction));
    if (result_->prediction.adequate) return Status::Ok();
    training_.insert(training_.end(), holdout_.begin(), holdout_.end());
    holdout_.clear();
    KCRIG_RETURN_IF_ERROR(FitNominal());
    result_->gap = true;
    result_->gap_source = "prediction";
    return Status::Ok();
  }

  AdequacyOptions AdequacyTests() const {
    return {options_.significance, options_.ljung_box_lags};
  }

  Status ModelResiduals(
      const EffectModel& model, const std::vector<double>& values,
      const std::vector<Experiment>& logs,
      std::vector<std::vector<Vec6<double>>>* weighted) const {
    weighted->assign(logs.size(), {});
    for (size_t l = 0; l < logs.size(); ++l) {
      KCRIG_RETURN_IF_ERROR(
          WeightedResiduals(model, values, logs[l], step_, &(*weighted)[l]));
    }
    return Status::Ok();
  }

  // Stage 2 (with Localize): per-log nominal fits, the stiffness drift
  // between experiments. A log whose own fit fails leaves the drift table
  // empty (it is evidence, not a precondition of the diagnosis).
  void EstimateDrift() {
    std::vector<EffectFit> per_log;
    std::vector<Status> per_log_status;
    RunFits(
        training_.size() > 1 ? static_cast<int>(training_.size()) : 0,
        [&](int l, EffectFit* fit) {
          return progress_.aborted()
                     ? Interrupted("diagnosis")
                     : FitEffectModel(nominal_model_, {training_[l]},
                                      result_->nominal.fit.values, fit_options_,
                                      step_, fit);
        },
        &per_log, &per_log_status);
    const bool available =
        std::all_of(per_log_status.begin(), per_log_status.end(),
                    [](const Status& s) { return s.ok(); });
    if (per_log.size() < 2 || !available) return;
    for (int i = 0; i < kNumBushings; ++i) {
      StiffnessDrift d;
      d.parameter = nominal_model_.parameters()[i].name;
      for (const EffectFit& f : per_log) {
        d.values.push_back(f.result.parameters[i].value);
        d.standard_errors.push_back(f.result.parameters[i].standard_error);
      }
      for (size_t a = 0; a < per_log.size(); ++a) {
        for (size_t b = a + 1; b < per_log.size(); ++b) {
          const double se =
              std::hypot(d.standard_errors[a], d.standard_errors[b]);
          if (std::isfinite(se) && se > 0) {
            d.max_z =
                std::max(d.max_z, std::abs(d.values[a] - d.values[b]) / se);
          }
        }
      }
      d.drifts = d.max_z > options_.drift_z;
      result_->drift_detected = result_->drift_detected || d.drifts;
      result_->drift.push_back(d);
    }
  }

  // Stage 3: the nominal model scored like the candidates will be; sets
  // the verdict rules, whose noise floor depends on what is scored.
  Status ScoreNominal() {
    ScoreModels({&nominal_model_}, {&result_->nominal});
    if (!result_->nominal.ok) return Status::Error(result_->nominal.error);
    long scored = m_;
    if (!holdout_.empty()) {
      scored = 0;
      for (const Experiment& e : holdout_) scored += 6L * ObservedCount(e);
    }
    rules_ = MakeVerdictRules(options_, !holdout_.empty(), m_, scored);
    nominal_gap_ = result_->nominal.score - 1.0;
    return Status::Ok();
  }

  // The candidates are scored on data that show the training logs' gap,
  // by the training logs' own tests (chi-square and Ljung-Box at the same
  // significance, or a score beyond the noise floor's spread). A hold-out
  // that does not neither confirms nor refutes it (its excitation may not
  // exercise the effect): the candidates are then scored by
  // cross-validation over the training logs (their information criteria
  // with one log), which see the training logs' gap by construction, and
  // the reason says so.
  Status ScoreWhereTheGapShows() {
    KCRIG_RETURN_IF_ERROR(ScoreNominal());
    // Cross-validation folds are judged by the training logs' own tests:
    // they show the gap by construction.
    if (result_->scoring != "holdout" || GapShows()) return Status::Ok();
    result_->scoring =
        training_.size() > 1 ? "cross_validation" : "information_criterion";
    char text[400];
    std::snprintf(
        text, sizeof(text),
        "the hold-out logs neither confirm nor refute the training logs' gap "
        "(nominal score %.4g, noise floor 1); scored by %s; a hold-out "
        "repeating %s's excitation would confirm or refute it: ",
        result_->nominal.score,
        result_->scoring == "cross_validation"
            ? "cross-validation over the training logs"
            : "the training log's information criteria",
        LargestGapLog().c_str());
    scoring_note_ = text;
    holdout_.clear();
    return ScoreNominal();
  }

  bool GapShows() const {
    return nominal_gap_ >= rules_.score_noise ||
           !rules_.AtNoise(result_->nominal);
  }

  // The training log whose nominal residual is largest.
  std::string LargestGapLog() const {
    double largest = -1;
    std::string source;
    for (size_t l = 0; l < training_.size(); ++l) {
      double sum = 0;
      for (const Vec6<double>& r : residuals_[l]) sum += r.squaredNorm();
      const double mean = sum / std::max(1, ObservedCount(training_[l]));
      if (mean > largest) {
        largest = mean;
        source = training_[l].source;
      }
    }
    return source;
  }

  // Scores models (their `fit` set) on data they were not fitted to: the
  // hold-out logs, or each training log predicted by the fit to the others
  // (one Gauss-Newton step from the full fit on the other logs: the
  // one-step approximation of the fold's refit; all folds of all models
  // side by side), or, with one log only, the training chi-square per
  // degree of freedom.
  void ScoreModels(const std::vector<const EffectModel*>& models,
                   const std::vector<CandidateScore*>& scores) {
    const int count = static_cast<int>(models.size());
    const int folds = result_->scoring == "cross_validation"
                          ? static_cast<int>(training_.size())
                          : 0;
    std::vector<std::vector<Vec6<double>>> fold_residuals;
    std::vector<Status> fold_status;
    std::vector<std::string> outcomes;
    Batches().Run(
        count * folds, options_.num_threads,
        [&](int job, std::string* outcome) {
          const int i = job / folds, l = job % folds;
          std::vector<Experiment> rest;
          for (int o = 0; o < folds; ++o) {
            if (o != l) rest.push_back(training_[o]);
          }
          std::vector<double> fold;
          std::vector<Vec6<double>> residuals;
          Status status = RefitOneStep(*models[i], scores[i]->fit.values, rest,
                                       step_, &fold);
          if (status.ok()) {
            status = WeightedResiduals(*models[i], fold, training_[l], step_,
                                       &residuals);
          }
          *outcome = EncodeResiduals(status, residuals);
        },
        &outcomes);
    fold_residuals.resize(outcomes.size());
    fold_status.resize(outcomes.size());
    for (size_t job = 0; job < outcomes.size(); ++job) {
      if (!DecodeResiduals(outcomes[job], &fold_status[job],
                           &fold_residuals[job])) {
        fold_status[job] = Status::Error("a fold's result arrived corrupt");
      }
    }
    for (int i = 0; i < count; ++i) {
      std::vector<Status> own_folds(fold_status.begin() + i * folds,
                                    fold_status.begin() + (i + 1) * folds);
      std::vector<std::vector<Vec6<double>>> own_residuals(
          fold_residuals.begin() + i * folds,
          fold_residuals.begin() + (i + 1) * folds);
      ScoreModel(*models[i], own_folds, own_residuals, scores[i]);
    }
  }

  void ScoreModel(const EffectModel& model,
                  const std::vector<Status>& fold_status,
                  const std::vector<std::vector<Vec6<double>>>& fold_residuals,
                  CandidateScore* s) {
    const int folds = static_cast<int>(fold_status.size());
    ScoreSum sum;
    s->model = model.Name();
    InformationCriteria(2 * s->fit.result.cost, model.num_parameters(), m_, s);
    Status st = Status::Ok();
    // Whiteness is tested where the chi-square of AtNoise is: on the
    // hold-out logs, else on the full fit's training residual.
    const std::vector<Experiment>& tested =
        holdout_.empty() ? training_ : holdout_;
    std::vector<std::vector<Vec6<double>>> w(tested.size());
    for (size_t l = 0; l < tested.size() && st.ok(); ++l) {
      st = WeightedResiduals(model, s->fit.values, tested[l], step_, &w[l]);
      if (st.ok() && !holdout_.empty()) sum.Add(tested[l], w[l]);
    }
    if (st.ok()) {
      s->ljung_box_p =
          WhitenessP(tested, w, kAllChannels, options_.ljung_box_lags);
    }
    if (holdout_.empty()) {
      for (int l = 0; l < folds && st.ok(); ++l) {
        st = fold_status[l];
        if (st.ok()) sum.Add(training_[l], fold_residuals[l]);
      }
    }
    s->ok = st.ok();
    s->error = st.message();
    if (!s->ok) return;
    s->scored = true;
    if (!holdout_.empty() || folds > 0) {
      s->heldout = true;
      s->score = sum.Score();
      s->heldout_rms = sum.Rms();
    } else {
      s->heldout = false;
      s->heldout_rms = Vec6<double>::Zero();
      s->score = s->train_chi2 / std::max(1, m_ - model.num_parameters());
    }
  }

  // Whether a model's best fit so far brought the training residual down
  // to the noise.
  bool FitsToNoise(const EffectModel& model, const CandidateScore& s,
                   bool fitted) const {
    const int dof = s.fit.result.num_residuals - model.num_parameters();
    return fitted && ChiSquareUpperTail(2 * s.fit.result.cost, dof) >=
                         options_.significance;
  }

  // kScaledStart in a model's starts: one Gauss-Newton step from its first
  // start on the training logs, the effect's size scaled from the residual
  // to first order (a hysteresis loop several times the starting values'
  // is reached; a start far from the effect's size can end in a local
  // minimum or, on a bound, as a fit that compensates for another effect).
  Status ScaledStart(const EffectModel& model, const Start& first,
                     Start* start) const {
    return RefitOneStep(model, first, training_, step_, start);
  }

  // Fits each model from its starts, one round of starts after the other:
  // while no model has brought the training residual down to the noise, a
  // further start is tried for at most `retry_pool` of the models that have
  // one, those that fit the training logs best so far first (the fits of
  // all models side by side). Then scores the best fit of each. `from`,
  // `to`: the progress fractions.
  void FitAndScore(const std::vector<const EffectModel*>& models,
                   const std::vector<std::vector<Start>>& starts, double from,
                   double to, std::vector<CandidateScore>* scores) {
    const int count = static_cast<int>(models.size());
    scores->assign(count, CandidateScore());
    std::vector<bool> fitted(count, false);
    std::vector<Status> fit_status(count, Status::Ok());
    size_t round_count = 0;
    for (const std::vector<Start>& s : starts) {
      round_count = std::max(round_count, s.size());
    }
    std::atomic<int> done{0};
    for (size_t round = 0; round < round_count; ++round) {
      bool any_at_noise = false;
      for (int i = 0; i < count; ++i) {
        any_at_noise |= FitsToNoise(*models[i], (*scores)[i], fitted[i]);
      }
      if (any_at_noise || progress_.aborted()) break;
      std::vector<int> todo;
      for (int i = 0; i < count; ++i) {
        if (round < starts[i].size()) todo.push_back(i);
      }
      if (round > 0) {
        // Unfitted models first, then by training cost.
        std::stable_sort(todo.begin(), todo.end(), [&](int a, int b) {
          if (fitted[a] != fitted[b]) return !fitted[a];
          return (*scores)[a].fit.result.cost < (*scores)[b].fit.result.cost;
        });
        if (static_cast<int>(todo.size()) > options_.retry_pool) {
          todo.resize(options_.retry_pool);
        }
      }
      std::vector<EffectFit> fits;
      std::vector<Status> status_of;
      RunFits(
          static_cast<int>(todo.size()),
          [&](int k, EffectFit* fit) {
            const int i = todo[k];
            Start start = starts[i][round];
            Status status =
                progress_.aborted() ? Interrupted("diagnosis") : Status::Ok();
            if (status.ok() && start.empty()) {
              status = ScaledStart(*models[i], starts[i][0], &start);
            }
            if (status.ok()) {
              status = FitEffectModel(*models[i], training_, start,
                                      candidate_fit_options_, step_, fit);
            }
            const int finished = ++done;
            Progress("candidate fits " + std::to_string(finished) + " (" +
                         models[i]->Name() + ")",
                     from + (to - from) * 0.9 *
                                std::min(1.0, static_cast<double>(finished) /
                                                  count));
            return status;
          },
          &fits, &status_of);
      for (size_t k = 0; k < todo.size(); ++k) {
        const int i = todo[k];
        if (!status_of[k].ok()) {
          if (!fitted[i]) fit_status[i] = status_of[k];
          continue;
        }
        if (!fitted[i] || fits[k].result.cost < (*scores)[i].fit.result.cost) {
          (*scores)[i].fit = fits[k];
        }
        fitted[i] = true;
      }
    }
    if (!Progress("scoring " + std::to_string(count) + " candidates (" +
                      result_->scoring + ")",
                  from + (to - from) * 0.9)
             .ok()) {
      return;
    }
    std::vector<const EffectModel*> ok_models;
    std::vector<CandidateScore*> ok_scores;
    for (int i = 0; i < count; ++i) {
      CandidateScore& s = (*scores)[i];
      s.model = models[i]->Name();
      if (!fitted[i]) {
        s.ok = false;
        s.error = fit_status[i].message();
        continue;
      }
      s.at_far_bound = AtFarBound(*models[i], s.fit.result);
      ok_models.push_back(models[i]);
      ok_scores.push_back(&s);
    }
    ScoreFitted(ok_models, ok_scores);
  }

  // Scores fitted models and the share of the nominal gap each closes.
  void ScoreFitted(const std::vector<const EffectModel*>& models,
                   const std::vector<CandidateScore*>& scores) {
    ScoreModels(models, scores);
    for (CandidateScore* s : scores) {
      s->gap_closed = s->ok && nominal_gap_ > 0
                          ? (result_->nominal.score - s->score) / nominal_gap_
                          : 0;
    }
  }

  // Stage 6b: the chosen candidate's fit refined from its values at
  // DiagnosisOptions::fit's tolerance (the nominal fit's) and scored again.
  // A refinement that fails, ends higher, or that the rules would refuse
  // (a failed score, a far bound, a gap no longer explained) leaves the
  // candidate's fit.
  Status RefineChosen(const CandidateScore* chosen) {
    if (chosen == nullptr || candidate_fit_options_.function_tolerance <=
                                 fit_options_.function_tolerance) {
      return Status::Ok();
    }
    KCRIG_RETURN_IF_ERROR(Progress("refining " + chosen->model, 0.995));
    CandidateScore& s = result_->ranking[chosen - result_->ranking.data()];
    EffectModel model;
    if (!EffectModel::CreateNamed(nominal_, s.model,
                                  options_.estimator.lower_scale,
                                  options_.estimator.upper_scale, &model)
             .ok()) {
      return Status::Ok();
    }
    std::vector<EffectFit> fits;
    std::vector<Status> status;
    RunFits(
        1,
        [&](int, EffectFit* fit) {
          return FitEffectModel(model, training_, s.fit.values, fit_options_,
                                step_, fit);
        },
        &fits, &status);
    if (!status[0].ok() || fits[0].result.cost > s.fit.result.cost) {
      return Status::Ok();
    }
    const CandidateScore candidate = s;
    s.fit = fits[0];
    s.at_far_bound = AtFarBound(model, s.fit.result);
    ScoreFitted({&model}, {&s});
    if (!s.ok || s.at_far_bound ||
        (rules_.Explains(candidate) && !rules_.Explains(s))) {
      s = candidate;
    }
    return Status::Ok();
  }

  // Whether an effect parameter of `fit` that measures the effect's size
  // (not a shape, EffectParameter::shape) stopped on a bound at least half
  // its range away from its "no effect" value (EffectParameter::initial;
  // for a freed model parameter, its configured value). The effect would need
  // more than its plausible range: the form is compensating for another.
  static bool AtFarBound(const EffectModel& model,
                         const EstimationResult& fit) {
    for (int i = kNumBushings; i < model.num_parameters() &&
                               i < static_cast<int>(fit.parameters.size());
         ++i) {
      const EffectParameter& p = model.parameters()[i];
      const ParameterEstimate& e = fit.parameters[i];
      if (!p.shape && e.at_bound &&
          std::abs(e.value - p.initial) >= 0.49 * (p.upper - p.lower)) {
        return true;
      }
    }
    return false;
  }

  // Stage 7: with no verdict, what the missing force looks like
  // (internal/discrepancy.h), in the reason's last sentence. Not when two
  // candidates explain the gap equally well: it is explained, twice.
  Status CharacteriseWhenUnexplained() {
    if (result_->verdict != "unexplained" || !result_->ambiguous_a.empty() ||
        options_.discrepancy.max_terms <= 0) {
      return Status::Ok();
    }
    KCRIG_RETURN_IF_ERROR(Progress("characterising the discrepancy", 0.95));
    // Evidence, not a precondition: a characterisation that fails leaves
    // the verdict standing and says why.
    const Status status = CharacteriseDiscrepancy(
        nominal_model_, result_->nominal.fit.values, training_, holdout_, step_,
        options_.discrepancy, &result_->discrepancy);
    if (!status.ok()) {
      result_->discrepancy = Discrepancy();
      result_->discrepancy.text =
          "the missing force could not be characterised: " + status.message();
    }
    result_->reason += ". " + result_->discrepancy.text;
    return Status::Ok();
  }

  // Stage 3b: wrong "known" parameters proposed by screening
  // (DiagnosisOptions::model_parameter_pool) join the single candidates.
  Status ProposeModelParameters() {
    if (options_.model_parameter_pool <= 0) return Status::Ok();
    KCRIG_RETURN_IF_ERROR(Progress("screening the model parameters", 0.12));
    const std::vector<double>& fitted = result_->nominal.fit.values;
    std::vector<ParameterLead> leads;
    const Status status = ScreenModelParameters(
        nominal_, {fitted.begin(), fitted.begin() + kNumBushings},
        FreeableModelParameters(), training_, step_, options_.num_threads,
        &leads);
    if (!status.ok()) {
      return Status::Error("diagnose: screening the model parameters: " +
                           status.message());
    }
    // BIC's price per freed parameter: a point frees three.
    const double price = std::log(static_cast<double>(m_));
    auto gain = [price](const ParameterLead& lead) {
      return lead.chi2_drop - price * lead.freed;
    };
    std::stable_sort(leads.begin(), leads.end(),
                     [&](const ParameterLead& a, const ParameterLead& b) {
                       return gain(a) > gain(b);
                     });
    result_->parameter_leads.assign(
        leads.begin(), leads.begin() + std::min<size_t>(5, leads.size()));
    int added = 0;
    for (const ParameterLead& lead : leads) {
      if (added == options_.model_parameter_pool ||
          gain(lead) < options_.min_bic_difference) {
        break;
      }
      const std::string name = FreedModelName(lead.name);
      const bool present =
          std::any_of(singles_.begin(), singles_.end(),
                      [&](const EffectModel& m) { return m.Name() == name; });
      EffectModel m;
      if (present ||
          !EffectModel::Create(nominal_, {name}, options_.estimator.lower_scale,
                               options_.estimator.upper_scale, &m)
               .ok()) {
        continue;
      }
      singles_.push_back(std::move(m));
      ++added;
    }
    return Status::Ok();
  }

  // Stage 4: each single effect from its starts: the nominal fit's
  // stiffnesses (which the effect has biased) with a small effect, then
  // that start scaled from the residual (kScaledStart), then the configured
  // stiffnesses with larger ones (two more for hysteresis).
  void FitSingles() {
    std::vector<const EffectModel*> models;
    std::vector<std::vector<Start>> starts;
    for (const EffectModel& single : singles_) {
      models.push_back(&single);
      // First from the nominal fit's (biased) stiffnesses, later ones from
      // the configured stiffnesses.
      Start biased;
      for (int p = 0; p < single.num_parameters(); ++p) {
        biased.push_back(p < kNumBushings ? result_->nominal.fit.values[p]
                                          : single.parameters()[p].initial);
      }
      starts.push_back({biased, kScaledStart});
      for (int k = 1; k < single.num_starts(); ++k) {
        starts.back().push_back(single.LaterStart(k));
      }
    }
    FitAndScore(models, starts, 0.15, 0.75, &result_->ranking);
    RankCandidates(&result_->ranking);
  }

  // A pair starts from its two single fits: the stiffnesses of its first
  // effect's, each effect's parameters from its own fit.
  Start PairStart(const EffectModel& pair) const {
    const std::vector<std::string> parts = pair.EffectNames();
    Start start;
    for (int p = 0; p < pair.num_parameters(); ++p) {
      const EffectParameter& ep = pair.parameters()[p];
      const bool stiffness = p < kNumBushings;
      start.push_back(stiffness ? result_->nominal.fit.values[p] : ep.initial);
      for (const CandidateScore& single : result_->ranking) {
        const bool owner = stiffness ? single.model == parts[0]
                                     : std::find(parts.begin(), parts.end(),
                                                 single.model) != parts.end();
        if (!single.ok || !owner) continue;
        const std::vector<ParameterEstimate>& fitted =
            single.fit.result.parameters;
        for (size_t q = 0; q < fitted.size(); ++q) {
          if (fitted[q].name == ep.FullName()) {
            start.back() = single.fit.values[q];
          }
        }
      }
    }
    return start;
  }

  // Stage 5: the best single effect when it decides; pairs of the best few
  // when the best leaves structure (chosen or not: two candidates that
  // explain most of the gap alike may be halves of a pair), and a pair
  // only when it beats the best single effect clearly too. Pairs join
  // the ranking.
  const CandidateScore* ChooseWithPairs() {
    std::vector<CandidateScore>& ranking = result_->ranking;
    const CandidateScore* chosen =
        rules_.Decides(ranking) ? &ranking[0] : nullptr;
    const bool try_pairs = options_.consider_pairs && ranking.size() > 1 &&
                           ranking[0].ok && !rules_.AtNoise(ranking[0]);
    if (!try_pairs) return chosen;
    // The best few, at most one freed parameter among them: parameters
    // near each other in the ranking are most often alternatives for one
    // error (the two ends of a link), and would crowd out the effects.
    std::vector<std::string> pool;
    bool has_parameter = false;
    for (const CandidateScore& s : ranking) {
      if (static_cast<int>(pool.size()) >= options_.pair_pool) break;
      const bool parameter = s.model.rfind(kModelParameter, 0) == 0;
      if (!s.ok || (parameter && has_parameter)) continue;
      has_parameter = has_parameter || parameter;
      pool.push_back(s.model);
    }
    std::vector<EffectModel> pair_models;
    for (size_t a = 0; a < pool.size(); ++a) {
      for (size_t b = a + 1; b < pool.size(); ++b) {
        EffectModel pm;
        if (EffectModel::Create(nominal_, {pool[a], pool[b]},
                                options_.estimator.lower_scale,
                                options_.estimator.upper_scale, &pm)
                .ok()) {
          pair_models.push_back(std::move(pm));
        }
      }
    }
    std::vector<const EffectModel*> pointers;
    std::vector<std::vector<Start>> pair_starts;
    for (const EffectModel& pm : pair_models) {
      pointers.push_back(&pm);
      pair_starts.push_back({PairStart(pm)});
    }
    std::vector<CandidateScore> pairs;
    FitAndScore(pointers, pair_starts, 0.75, 0.97, &pairs);
    if (progress_.aborted()) return nullptr;
    RankCandidates(&pairs);
    const bool pair_wins =
        rules_.Decides(pairs) && rules_.ClearlyBetter(pairs[0], ranking[0]);
    const std::string chosen_name = pair_wins           ? pairs[0].model
                                    : chosen != nullptr ? chosen->model
                                                        : "";
    ranking.insert(ranking.end(), pairs.begin(), pairs.end());
    RankCandidates(&ranking);
    for (const CandidateScore& s : ranking) {
      if (s.model == chosen_name) return &s;
    }
    return nullptr;
  }

  // Stage 6: effects placed on the components they act in
  // (DiagnosisOptions::place_components; PlaceableComponents: bushings,
  // fixture axes, actuator axes, sensor channels): the chosen one when it is
  // placeable,
  // else, with nothing chosen, every placeable effect (a worn bushing is one
  // component: the effect in all five explains it badly, and how badly says
  // little about which effect it is). Placed models start from their
  // effect's global fit and join the ranking; returns the chosen model.
  const CandidateScore* PlaceOnComponents(const CandidateScore* chosen) {
    if (!options_.place_components) return chosen;
    // The chosen effect everywhere leaves only noise, or nothing was chosen
    // and the best, no placeable effect, does: no placement can explain
    // more (it could only tie, and the data cannot place the effect), and
    // an ambiguity stands.
    const CandidateScore& leader = result_->ranking.front();
    if (chosen != nullptr
            ? rules_.AtNoise(*chosen)
            : leader.ok && !Placeable(leader.model) && rules_.AtNoise(leader)) {
      return chosen;
    }
    std::vector<CandidateScore> globals;
    for (const CandidateScore& s : result_->ranking) {
      const bool wanted = chosen == nullptr || s.model == chosen->model;
      if (wanted && s.ok && Placeable(s.model)) globals.push_back(s);
    }
    // Each effect on each single component; the one that scores best is
    // extended, component by component (the others' fits would only cost
    // time).
    std::vector<CandidateScore> tried;
    const CandidateScore* global = nullptr;
    CandidateScore placed;
    for (const CandidateScore& g : globals) {
      CandidateScore start;
      if (!StartPlacement(g, &start, &tried)) continue;
      if (progress_.aborted()) return chosen;
      if (global == nullptr || start.score < placed.score) {
        global = &g;
        placed = start;
      }
    }
    if (progress_.aborted() || global == nullptr) return chosen;
    if (!NarrowsFromAll(ClassOf(global->model))) {
      ExtendPlacement(*global, &placed, &tried);
    }
    // The lower score; the global form when they tie. A fixture's
    // placement must improve on the global form (its translational axes):
    // it has a parameter more where it rotates, and the axes it drops are
    // often only unloaded.
    const bool replaces = NarrowsFromAll(ClassOf(global->model))
                              ? Improves(placed, *global)
                              : placed.score < global->score;
    const std::string best = replaces ? placed.model : global->model;
    if (progress_.aborted()) return chosen;
    const bool decided = chosen != nullptr;  // `chosen` dangles after insert
    std::vector<CandidateScore>& ranking = result_->ranking;
    ranking.insert(ranking.end(), tried.begin(), tried.end());
    RankCandidates(&ranking);
    const CandidateScore* pick = nullptr;
    for (const CandidateScore& s : ranking) {
      if (s.model == best) pick = &s;
    }
    if (decided || pick == nullptr) return pick;
    // Nothing was chosen: the placement decides against the other effects
    // (not against its own effect elsewhere, which it has beaten already).
    std::vector<CandidateScore> contenders = {*pick};
    const std::string effect = ClassOf(best);
    for (const CandidateScore& s : ranking) {
      if (ClassOf(s.model) != effect) contenders.push_back(s);
    }
    return rules_.Decides(contenders) ? pick : nullptr;
  }

  static std::string ClassOf(const std::string& model) {
    return model.substr(0, model.find('@'));
  }
  // A single effect's global form (not already placed by hand) that has
  // components.
  static bool Placeable(const std::string& model) {
    return model.find_first_of("+@") == std::string::npos &&
           !PlaceableComponents(model).empty();
  }

  // A fixture's axes give together (its mounts carry the load in every
  // direction), so its placement starts from every axis and drops those the
  // data do not need; a bushing's wear or a sensor's error is one
  // component, so theirs starts from the single components and adds.
  static bool NarrowsFromAll(const std::string& effect) {
    return effect == "rig_compliance";
  }

  // The placement of `global`'s effect the selection starts from: its best
  // single component, or, for NarrowsFromAll, every component narrowed to
  // those the data need. Every fit joins `tried`; false when none fits.
  bool StartPlacement(const CandidateScore& global, CandidateScore* start,
                      std::vector<CandidateScore>* tried) {
    const std::string effect = ClassOf(global.model);
    std::vector<CandidateScore> scores =
        NarrowsFromAll(effect) ? FitSets(global, {LoadedComponents(effect)})
                               : FitPlacements(global, {});
    tried->insert(tried->end(), scores.begin(), scores.end());
    if (scores.empty() || !scores[0].ok) return false;
    *start = scores[0];
    // On every axis the effect explains nothing: fewer axes cannot either.
    if (NarrowsFromAll(effect) && Improves(*start, result_->nominal)) {
      NarrowPlacement(global, start, tried);
    }
    return true;
  }

  // The components of `effect` the training logs load (LoadsComponent):
  // the others' placements would only tie.
  std::vector<std::string> LoadedComponents(const std::string& effect) const {
    std::vector<std::string> loaded;
    for (const std::string& c : PlaceableComponents(effect)) {
      if (LoadsComponent(training_, c)) loaded.push_back(c);
    }
    return loaded;
  }

  // Backward elimination from `placed`: drop the component whose removal
  // costs least while the score stays within the noise floor's spread of
  // the start's (the data cannot tell the effect there; measured from the
  // start, so that the drops cannot add up). Every fit joins `tried`.
  void NarrowPlacement(const CandidateScore& global, CandidateScore* placed,
                       std::vector<CandidateScore>* tried) {
    const double start_score = placed->score;
    for (std::vector<std::string> set = ModelComponents(placed->model);
         set.size() > 1; set = ModelComponents(placed->model)) {
      std::vector<std::vector<std::string>> smaller;
      for (size_t k = 0; k < set.size(); ++k) {
        smaller.push_back(set);
        smaller.back().erase(smaller.back().begin() + k);
      }
      std::vector<CandidateScore> scores = FitSets(global, smaller);
      if (progress_.aborted() || scores.empty()) return;
      tried->insert(tried->end(), scores.begin(), scores.end());
      if (!scores[0].ok || scores[0].score - start_score > rules_.score_noise) {
        return;
      }
      *placed = scores[0];
    }
  }

  // Forward selection of the components `global`'s effect acts on, from
  // `placed` (its best single component): add the component that improves
  // the score most while it Improves it, short of every component where
  // that is `global`, and within a candidate's parameters. Every fit joins
  // `tried`.
  void ExtendPlacement(const CandidateScore& global, CandidateScore* placed,
                       std::vector<CandidateScore>* tried) {
    const std::string effect = ClassOf(global.model);
    // A bushing effect's or an actuator lag's global form acts on every
    // component: the selection stops short of it.
    const bool global_is_every =
        IsBushingEffect(effect) || effect == "actuator_lag";
    const size_t loaded = LoadedComponents(effect).size();
    const size_t most = global_is_every && loaded > 0 ? loaded - 1 : loaded;
    for (std::vector<std::string> set = ModelComponents(placed->model);
         set.size() < most; set = ModelComponents(placed->model)) {
      std::vector<CandidateScore> scores = FitPlacements(global, set);
      if (progress_.aborted() || scores.empty()) return;
      tried->insert(tried->end(), scores.begin(), scores.end());
      if (!Improves(scores[0], *placed)) return;
      *placed = scores[0];
    }
  }

  // `global`'s effect on `set` plus each component not in it (FitSets).
  std::vector<CandidateScore> FitPlacements(
      const CandidateScore& global, const std::vector<std::string>& set) {
    std::vector<std::vector<std::string>> larger;
    for (const std::string& added : LoadedComponents(ClassOf(global.model))) {
      if (std::find(set.begin(), set.end(), added) != set.end()) continue;
      larger.push_back(set);
      larger.back().push_back(added);
    }
    return FitSets(global, larger);
  }

  // `global`'s effect on each of `sets`, fitted from the global fit's values
  // (the parameters they share), then from the effect's later starts as the
  // candidates are, and ranked. A set the effect cannot take (too many
  // parameters) is left out.
  std::vector<CandidateScore> FitSets(
      const CandidateScore& global,
      const std::vector<std::vector<std::string>>& sets) {
    const std::string effect = ClassOf(global.model);
    EffectModel global_model;
    if (!EffectModel::CreateNamed(nominal_, global.model,
                                  options_.estimator.lower_scale,
                                  options_.estimator.upper_scale, &global_model)
             .ok()) {
      return {};
    }
    std::vector<EffectModel> models;
    for (const std::vector<std::string>& set : sets) {
      std::string place;
      for (const std::string& c : set) place += (place.empty() ? "" : "+") + c;
      EffectModel m;
      // A set that is the global form's is already ranked as `global`.
      if (EffectModel::Create(nominal_, {effect + "@" + place},
                              options_.estimator.lower_scale,
                              options_.estimator.upper_scale, &m)
              .ok() &&
          m.Name() != global.model) {
        models.push_back(std::move(m));
      }
    }
    std::vector<const EffectModel*> pointers;
    std::vector<std::vector<Start>> starts;
    for (const EffectModel& m : models) {
      pointers.push_back(&m);
      starts.push_back(
          {m.StartFrom(global_model, global.fit.values), kScaledStart});
      // The effect's own later starts: the global fit's values can sit in
      // a local minimum of the placed effect (a Dahl force spread over five
      // bushings is not one bushing's).
      for (int k = 1; k < m.num_starts(); ++k) {
        starts.back().push_back(m.LaterStart(k));
      }
    }
    std::vector<CandidateScore> scores;
    FitAndScore(pointers, starts, 0.97, 0.99, &scores);
    RankCandidates(&scores);
    return scores;
  }

  // Whether `a` lowers `b`'s score beyond the noise floor's spread and its
  // BIC by min_bic_difference (models with as many parameters: the
  // chi-square's difference).
  bool Improves(const CandidateScore& a, const CandidateScore& b) const {
    return a.ok && b.score - a.score > rules_.score_noise &&
           b.bic - a.bic >= rules_.min_bic_difference;
  }

  const SuspensionParameters<double>& nominal_;
  // Copies: a hold-out whose gap shows only in its prediction joins the
  // training logs (JoinHoldoutWhenMispredicted).
  std::vector<Experiment> training_;
  std::vector<Experiment> holdout_;
  const DiagnosisOptions& options_;
  const double step_;
  DiagnosisResult* const result_;
  const std::chrono::steady_clock::time_point start_;

  EffectModel nominal_model_;
  std::vector<EffectModel> singles_;
  EffectFitOptions fit_options_;
  EffectFitOptions candidate_fit_options_;  // DiagnosisOptions' tolerance
  ProgressReporter progress_;
  // The nominal fit's weighted training residuals and their count.
  std::vector<std::vector<Vec6<double>>> residuals_;
  int m_ = 0;
  double nominal_gap_ = 0;
  // Why the candidates are not scored on the first data tried
  // (ScoreWhereTheGapShows); empty when they are.
  std::string scoring_note_;
  VerdictRules rules_;
};

}  // namespace

Status Diagnose(const SuspensionParameters<double>& nominal,
                const std::vector<Experiment>& training,
                const std::vector<Experiment>& holdout,
                const DiagnosisOptions& options, double step,
                DiagnosisResult* result) {
  return DiagnosisRun(nominal, training, holdout, options, step, result).Run();
}

}  // namespace kcrig
