// The sim-to-real gap diagnosis: is there a gap between the nominal model
// and the logs beyond the sensor noise, where does it lie (channel, load
// regime, frequency band, lag, drift of the stiffnesses between
// experiments), which unmodelled effect of the library explains it
// (candidate models refitted and scored on data they were not fitted to),
// and how much of the gap that effect closes.
//
// Scores are mean squared weighted residuals S = |r / sigma|^2 / n on
// held-out data: 1 is the noise floor, S - 1 the gap. A candidate closes
// (S_nominal - S) / (S_nominal - 1) of it. Without hold-out logs the score
// is a blocked cross-validation over whole training logs (each log
// predicted by the fit to the others, approximated by one Gauss-Newton step
// from the fit to all); with a single log and no hold-out
// only the information criteria are left, and the result says so.
#ifndef KCRIG_DIAGNOSIS_DIAGNOSIS_H_
#define KCRIG_DIAGNOSIS_DIAGNOSIS_H_

#include <string>
#include <vector>

#include "base/batch_runner.h"
#include "base/iteration_callback.h"
#include "base/parallel_for.h"
#include "base/status.h"
#include "estimator/adequacy.h"
#include "estimator/effect_model.h"
#include "estimator/experiment.h"

namespace kcrig {

// The characterisation of a gap no candidate explains
// (internal/discrepancy.h).
struct DiscrepancyOptions {
  // At most this many terms; 0: not characterised.
  int max_terms = 4;
  // A term must lower the training RSS by the BIC's ln(m) and this much
  // more (strong evidence), and with two or more fitted logs their
  // cross-validated RSS by this much.
  double min_bic_difference = 10;
  // The terms describe the missing force only when they close at least
  // this fraction of the gap on the validation logs; else the text says
  // that nothing in the links or the strut predicts it.
  double min_gap_closed = 0.5;
};

struct DiagnosisOptions {
  // Bounds of the bushing stiffnesses (x nominal) and the uncertainty
  // thresholds, as for `kcrig estimate`.
  EstimatorOptions estimator;
  // The nominal fit's and the verdict's model's fit. The candidates' fits
  // stop earlier, when a step lowers the cost by less than
  // candidate_function_tolerance of it (1e-6: under 0.1 of chi-square in
  // 10^4 residuals, far below the differences that rank them), which
  // spares the fifth of a diagnosis spent creeping to the last digits;
  // the chosen candidate is then refined from its values at
  // fit.function_tolerance and scored again, so that its values and
  // intervals are as precise as the nominal fit's. The alternatives of an
  // ambiguous or unexplained verdict keep their candidates' fits.
  EffectFitOptions fit;
  double candidate_function_tolerance = 1e-6;
  // The candidate effects (names of kEffectNames, placed ones, or
  // model_parameter@NAME).
  std::vector<std::string> candidates = {kEffectNames.begin(),
                                         kEffectNames.end()};
  // Gap test: the nominal residual is noise unless the chi-square test or
  // a Ljung-Box test (Bonferroni over logs x channels) rejects at this
  // level.
  double significance = 1e-3;
  int ljung_box_lags = 20;
  // Largest lag of the residual-force cross-correlation [s].
  double max_lag = 0.1;
  // The best candidate is the verdict only when it closes at least this
  // fraction of the held-out gap, or leaves only noise there (a hold-out
  // that shows a gap of a few standard deviations measures the fraction
  // closed no better than that)...
  double min_gap_closed = 0.8;
  // ...and is clearly better than the runner-up: it closes at least
  // min_gap_margin more of the gap, or the runner-up leaves three times its
  // remaining gap open (at least five standard deviations of a score at the
  // noise floor); and the BIC prefers it by at least min_bic_difference
  // (strong evidence). A pair of effects must be clearly better than the
  // best single one in the same sense.
  double min_gap_margin = 0.2;
  double min_bic_difference = 10;
  // Confidence: "high" when the verdict leaves only noise, or when it
  // closes at least high_confidence_gap_closed of the gap and the best
  // candidate of every other class (its rival: another effect, another
  // freed parameter) leaves at least high_confidence_separation times its
  // remaining gap (not less than five standard deviations of a score at
  // the noise floor): an effect of another form than the candidate's
  // leaves structure, but no other fault comes near.
  double high_confidence_gap_closed = 0.9;
  double high_confidence_separation = 10;
  // Pairs of effects are tried, from the best `pair_pool` single ones (at
  // most one freed model parameter among them), when the best one leaves
  // structure beyond the noise.
  bool consider_pairs = true;
  int pair_pool = 3;
  // A single placeable effect as the verdict (PlaceableComponents: a
  // bushing effect, rig_compliance, actuator_lag, sensor_offset) is placed
  // on the components it acts on, those the training logs load
  // (LoadsComponent). Bushings, actuator axes and sensor
  // channels: forward selection from the best single component, adding the
  // one that lowers the score most while it lowers it beyond the noise
  // floor's spread and the BIC by min_bic_difference; the placement is the
  // verdict when it scores lower than the global form. Fixture axes:
  // backward elimination from every axis, dropping the one whose removal
  // costs least while the score stays within the noise floor's spread (not
  // when every axis does not improve on the nominal model); the
  // placement is the verdict when it improves on the global (translational)
  // form as forward selection's steps must. With no verdict, every
  // placeable effect is placed so and the best placement, clearly better
  // than the other effects, is the verdict. Not when the global form (or,
  // with no verdict, the best other candidate) leaves only noise: a
  // placement could only tie.
  bool place_components = true;
  // Wrong "known" parameters: the model parameters (FreeableModelParameters;
  // a hard point whole) whose freeing removes the most of the nominal fit's
  // training chi-square to first order (ScreenModelParameters) beyond the
  // BIC's price of what they free, at most this many and each by more than
  // min_bic_difference, join the candidates as model_parameter@<name>.
  // 0: none.
  int model_parameter_pool = 3;
  // With no verdict, what the missing force looks like.
  DiscrepancyOptions discrepancy;
  // A stiffness estimated from single logs drifts when two logs disagree by
  // more than this many combined standard errors.
  double drift_z = 4;
  // When no candidate's first fit brings the training residual down to
  // the noise, further starts are tried, one round each, for at most
  // `retry_pool` of the candidates that have a start for the round, the
  // best fitting first: the first start scaled from the residual (one
  // Gauss-Newton step on the training logs: an effect several times the
  // starting values' size is reached), then the effects' later starts
  // (effect_model.h: later_starts). A candidate with more starts than the
  // others, hysteresis, gets them even when it fits worse: its landscape,
  // not its model, is then the likelier cause.
  int retry_pool = 2;
  // Candidates are fitted on this many threads, in this process or, with
  // `batches`, spread over a cluster job's ranks (cluster/ranks.h: every
  // rank then runs the same diagnosis and gets every fit). Optional.
  int num_threads = kDefaultThreads;
  const BatchRunner* batches = nullptr;
  // Every log needs at least this many observed samples.
  int min_samples = 500;
  // Asked with a short line at each stage and after each candidate fit,
  // and with that line again during every fit (one call at a time, from
  // any thread); kAbort stops the diagnosis with Interrupted(). The fit
  // options' callback is replaced by it. Optional.
  IterationCallback callback;
};

// Residual energy of the nominal fit in one slice of the data.
struct GapSlice {
  std::string name;
  int samples = 0;
  // Mean squared weighted residual over the slice (1: noise) and per
  // channel; the slice's share of the total excess energy sum(w^2 - 1).
  double score = 0;
  Vec6<double> channel_score = Vec6<double>::Zero();
  double excess_share = 0;
  // The residual's mean (a bias, e.g. an offset) and RMS per channel
  // [m, rad].
  Vec6<double> mean = Vec6<double>::Zero();
  Vec6<double> rms = Vec6<double>::Zero();
};

struct FrequencyBand {
  double low_hz = 0, high_hz = 0;
  // Share of the residual energy in the band, and the share white noise
  // would have (the band's width over the Nyquist frequency).
  double energy_share = 0;
  double white_share = 0;
};

struct LagCorrelation {
  std::string channel;
  // Peak of the cross-correlation of the weighted residual with the force
  // along the excitation direction and with its rate, over lags within
  // max_lag (positive: the residual follows the force). [s], [-].
  double force_lag = 0, force_correlation = 0;
  double rate_lag = 0, rate_correlation = 0;
};

struct StiffnessDrift {
  std::string parameter;
  std::vector<double> values;           // one per training log [N/m]
  std::vector<double> standard_errors;  // [N/m]
  double max_z = 0;                     // largest pairwise disagreement
  bool drifts = false;
};

// One term of the discrepancy characterisation: a force in one element as
// a coefficient times a named function of its elongation d, rate v or time.
struct DiscrepancyTerm {
  std::string component;  // "bushing:V1", "strut:spring", "strut:damper"
  std::string term;       // "d^2", "d^3", "sign(d)", "v", "sign(v)", "t*d", "d"
  double coefficient = 0;  // SI: N per the term's unit
  std::string unit;        // of the coefficient: "N/m^2", "N", "N s/m", ...
  double force_rms = 0;    // RMS of the term's force over the training logs [N]
  std::string words;       // "a force of about 60 N opposing ..."
};

// What the missing force looks like when no candidate explains the gap: a
// sparse combination of physically named terms per element, chosen by
// forward selection with the BIC on the training logs (the bushing
// stiffnesses refitted beside them) and validated on data not fitted.
struct Discrepancy {
  std::vector<DiscrepancyTerm> terms;  // largest force first
  // "holdout", "last training log" (fitted to the others), or "none".
  std::string validated_on;
  // Fraction of the nominal gap the terms close on the validation logs
  // (NaN when not validated) and on the training logs.
  double gap_closed = 0;
  double training_gap_closed = 0;
  // The terms close at least DiscrepancyOptions::min_gap_closed of the
  // gap on the validation logs: only then does the text present them as
  // the missing force.
  bool predictive = false;
  std::string text;  // the dominant terms in one sentence
};

struct CandidateScore {
  std::string model;  // "nominal", an effect, or "a+b"
  EffectFit fit;      // on all training logs
  double train_chi2 = 0;
  int num_parameters = 0;
  double bic = 0, aicc = 0;
  // Held-out (or cross-validated) score, its per-channel RMS [m, rad] and
  // the fraction of the nominal gap closed.
  // `scored`: score and gap_closed were computed (not when the verdict is
  // `none`); `heldout`: heldout_rms too (not with one log and no hold-out).
  double score = 0;
  Vec6<double> heldout_rms = Vec6<double>::Zero();
  double gap_closed = 0;
  // Whiteness of the residual on the scored data (the hold-out logs, else
  // the training logs): the smallest Ljung-Box p-value, Bonferroni-corrected.
  double ljung_box_p = 1;
  bool scored = false;
  bool heldout = false;
  // An effect parameter stopped on the bound of its range away from "no
  // effect" (a hard point 50 mm off): the form compensates for another
  // effect; never the verdict.
  bool at_far_bound = false;
  bool ok = true;  // false: the fit failed (error says why)
  std::string error;
};

// A hard point the verdict's model frees whole (model_parameter@O1): how
// far it sits from its configured place, and the uncertainty of that move.
// The truth lies in the 95 % region dT C^-1 d <= kHardPointRegion95 (d the
// true move less `displacement`, C `covariance`) with 95 % probability; a
// coordinate the data do not determine leaves it unbounded (`bounded`).
struct HardPointMove {
  std::string point;                                     // "O1"
  Eigen::Vector3d configured = Eigen::Vector3d::Zero();  // [m] x y z
  Eigen::Vector3d displacement =
      Eigen::Vector3d::Zero();  // [m] fitted - configured
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // [m^2]
  bool bounded = false;
  bool at_bound = false;  // a coordinate stopped on its range's bound
};
// The chi-square quantile of three degrees of freedom at 95 %.
inline constexpr double kHardPointRegion95 = 7.814727903251178;

struct DiagnosisResult {
  // Gap test on the nominal fit.
  double chi2 = 0;
  int dof = 0;
  double chi2_p = 1;
  double ljung_box_p = 1;  // smallest, Bonferroni-corrected
  // The nominal model's own discretisation error [sigma, largest channel
  // RMS] and whether the gap test judged its continuous-time limit (the
  // error set apart: the logs come from a continuous rig, not the scheme).
  double discretisation = 0;
  bool continuous_limit = false;
  bool gap = false;
  // Where the gap showed: "training" (the nominal fit's residual),
  // "prediction" (only in the nominal fit's prediction of the hold-out
  // logs: an effect absorbed by biased stiffnesses; the hold-out then joined
  // the training logs and the candidates were cross-validated), "" without
  // a gap.
  std::string gap_source;
  // The hold-out logs predicted by the nominal fit to the training logs
  // (assessed only when the training fit showed no gap).
  Adequacy prediction;
  // Where the gap lies (nominal fit, training logs).
  std::vector<GapSlice> channels;   // x .. caster
  std::vector<GapSlice> magnitude;  // near_zero, low, mid, high |F|
  std::vector<GapSlice> direction;  // loading, unloading, hold
  std::vector<FrequencyBand> bands;
  std::vector<LagCorrelation> lags;
  std::vector<StiffnessDrift> drift;  // with two or more training logs
  bool drift_detected = false;
  // The model parameters the screening found most promising (at most five,
  // the largest chi-square drop beyond BIC's price of what each frees
  // first; empty when it did not run).
  std::vector<ParameterLead> parameter_leads;
  // How candidates were scored: "holdout", "cross_validation" or
  // "information_criterion".
  std::string scoring;
  // The nominal model first, then the candidates ranked best first.
  CandidateScore nominal;
  std::vector<CandidateScore> ranking;
  // The verdict: "none", an effect, "a+b", or "unexplained"; confidence
  // "high" or "low" ("" for none); why, in one line.
  std::string verdict;
  // The verdict's model as fitted, with where its effects act
  // ("hysteresis@bushing:V1"; equal to the verdict when nothing is placed,
  // "" for none and unexplained), and those places in the component
  // vocabulary (plant_effects.h; ModelComponents): the bushings, fixture
  // axes, actuator axes or sensor channels its effects act on, a freed
  // parameter's component.
  std::string model;
  std::vector<std::string> components;
  // The hard points the verdict's model moves (none when it frees none).
  std::vector<HardPointMove> hard_points;
  // The verdict's model leaves only noise on the scored logs
  // (VerdictRules::AtNoise).
  bool leaves_noise = false;
  std::string confidence;
  std::string reason;
  // The best candidate of another class than the verdict's, and how many
  // times the verdict's remaining gap it leaves (the measure of
  // confidence; "" and 0 without a verdict or a rival).
  std::string rival;
  double rival_separation = 0;
  // Two candidates the data cannot tell apart (both empty otherwise): the
  // caller may design an experiment that discriminates them.
  std::string ambiguous_a, ambiguous_b;
  // With `unexplained` and a gap: the characterisation of the missing force
  // (empty terms when none is significant).
  Discrepancy discrepancy;
  double seconds = 0;
};

// Diagnoses the gap of `training` (and, when given, scores on `holdout`).
// Errors on unusable input: no training log, a log shorter than
// min_samples observed samples, unknown candidates.
Status Diagnose(const SuspensionParameters<double>& nominal,
                const std::vector<Experiment>& training,
                const std::vector<Experiment>& holdout,
                const DiagnosisOptions& options, double integrator_step,
                DiagnosisResult* result);

}  // namespace kcrig

#endif  // KCRIG_DIAGNOSIS_DIAGNOSIS_H_
