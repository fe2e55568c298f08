// The two-level scheme of the paper (Fig. 3 loop): estimate the parameters
// from all logs so far, report their uncertainty, design the next
// excitation for the criterion given the information already collected
// (sequential design: Phi(I_data + I(v))), run it on the rig, add the log,
// repeat until every 95 % interval is narrow enough or the iterations are
// spent. The rig is anything that turns a design into a log.
//
// The model is never trusted blindly: every iteration checks the fit's
// adequacy, the prediction of the new experiment by the previous estimate
// and the consistency of the estimates with the previous intervals. When a
// check fails, the logs are diagnosed and the verdict acted on (an effect
// adopted into the model, a discriminating experiment next, or a stop).
#ifndef KCRIG_CAMPAIGN_CAMPAIGN_H_
#define KCRIG_CAMPAIGN_CAMPAIGN_H_

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "base/iteration_callback.h"
#include "designer/design_io.h"
#include "designer/optimizers.h"
#include "diagnosis/diagnosis.h"
#include "diagnosis/isolability.h"
#include "estimator/estimator.h"
#include "rt_core/model/model_config.h"

namespace kcrig {

// Runs `excitation` (a design with the config's Fmax and tf) as run number
// `run` and writes its log (run.csv + sidecar) to `csv_path`.
using RigRunner = std::function<Status(const RampExcitation<double>& excitation,
                                       int run, const std::string& csv_path)>;

struct CampaignIteration;

struct CampaignOptions {
  // Designed experiments after the initial one (paper's design from
  // experiment.yaml); each is followed by a new estimate.
  int iterations = 3;
  // Stop early when every estimated parameter's 95 % interval half-width is
  // at most this fraction of its value (0.005: +-0.5 %).
  double target_relative_halfwidth = 0.0;
  Criterion criterion = Criterion::kD;
  std::string optimizer = "kriging";
  // Budget and threads of each design, and the estimator's options; their
  // callbacks are replaced by `callback`.
  ObjectiveOptions objective;
  OptimizerOptions optimizer_options;
  EstimatorOptions estimator;
  // An estimate that moves by more than this many combined standard errors
  // from the previous iteration's says the intervals were not to be trusted
  // (combined for nested estimates: Var(new - old) = se_old^2 - se_new^2).
  double max_consistency_z = 4;
  // When an iteration fails a check (fit, prediction, consistency), the
  // campaign diagnoses its logs (the newest as hold-out) and acts on the
  // verdict: an attributed effect is adopted into the model of the
  // following iterations, two tied candidates get the discriminating
  // experiment next, `unexplained` stops the campaign. Needs the estimator's
  // parameters to be the five bushing stiffnesses (the diagnosis' model).
  bool close_loop = true;
  DiagnosisOptions diagnosis;
  // Which faults the logs so far tell apart, each iteration, and with the
  // next experiment added (diagnosis/isolability.h); its callback and
  // threads are the campaign's. Off by default: it costs about as much
  // again as the rest of an iteration on the embedded rig (two trajectories
  // with sensitivities per candidate, 47 candidates).
  bool isolability = false;
  IsolabilityOptions isolability_options;
  // Asked at each stage ("iteration 1: designing (D, kriging)"), after each
  // batch of a design ("<stage> | kriging: 24/100 evaluations, ...") and
  // with the stage again during each estimate; kAbort stops the campaign
  // with Interrupted(), the iterations completed so far kept. Optional.
  IterationCallback callback;
  // Called with each iteration as soon as it is complete (its results, not
  // progress).
  std::function<void(const CampaignIteration&)> on_iteration;
};

struct CampaignIteration {
  int index = 0;
  std::vector<std::string> logs;  // all logs the estimate used
  Design experiment;              // of the newest log
  // Its excitation when it was not the campaign's usual ramp at
  // `experiment` (a discriminating experiment), else empty.
  std::optional<RampExcitation<double>> special_excitation;
  // The model of `estimate`: "nominal", or an adopted effect ("a" or "a+b",
  // whose parameters follow the bushings' in `estimate`).
  std::string model = "nominal";
  EstimationResult estimate;  // its adequacy: of the fit to all logs
  // The integrator step `estimate` was fitted at [s]: the configured one,
  // or with an adopted effect down to an eighth of it (see
  // EffectFitOptions::max_step_halvings). 0: the configured one.
  double model_step = 0;
  // With an adopted effect, the nominal model's fit to the same logs, for
  // comparison (empty parameters otherwise).
  EstimationResult nominal_estimate;
  // The newest log predicted by the previous iteration's estimate before
  // it was fitted: a true hold-out (designed, not fitted). Not assessed at
  // iteration 0.
  Adequacy prediction;
  // The largest change of an estimate from the previous iteration's, in
  // combined standard errors (0 at iteration 0), and whose it is.
  double consistency_z = 0;
  std::string least_consistent;
  bool consistent = true;  // consistency_z <= max_consistency_z
  // The checks the iteration's first fit failed, as CampaignCheck said
  // before the campaign acted on them ("ok" when none).
  std::string failed_checks = "ok";
  // The diagnosis run because a check failed, and what the campaign did:
  // "adopted" (its effect is `model` from here on), "discriminate" (the
  // next experiment tells two candidates apart), "undecided" (unexplained
  // on one log: the next experiment is designed as usual and the diagnosis
  // repeated), "stopped" (unexplained: no more designs), "none" (the
  // diagnosis found no gap).
  bool diagnosed = false;
  DiagnosisResult diagnosis;
  std::string action;
  // Why the diagnosis' effect was not adopted: the model with it fails the
  // fit's adequacy too ("" when adopted or none was attributed).
  std::string rejected_adoption;
  // Which faults the logs so far tell apart (with `isolability`), and how
  // many ties remain once the next experiment is added (-1: none planned).
  Isolability isolability;
  int ties_with_next = -1;
  std::string isolability_error;  // why it was not judged ("" when it was)
  bool designed = false;          // false on the last iteration
  double criterion_of_data = 0;   // Phi(I_data)
  DesignRun design;               // Phi(I_data + I(v)) from v0 to v*
};

// "ok", or which checks an iteration's estimate fails ("inadequate fit",
// "mispredicted", "inconsistent", comma-separated); after an adoption only
// the adopted fit's adequacy (the checks that led to it: `failed_checks`).
std::string CampaignCheck(const CampaignIteration& iteration);

// The options' errors before anything runs: iterations, target width,
// optimizer name, budget, design bounds, parameter names.
Status ValidateCampaignOptions(const KcrigConfig& config,
                               const CampaignOptions& options);

// One iteration's entry of campaign.json (an element of its "iterations"),
// as the iteration lands, for display (the live console): invalid UTF-8 in
// a path is replaced.
std::string CampaignIterationToJson(const CampaignIteration& it);

// campaign.json: per iteration the logs, the experiment, the estimates with
// intervals and log10 diag((J^T J)^-1), the criterion and the next design.
std::string CampaignToJson(Criterion criterion,
                           const std::vector<CampaignIteration>& iterations);

// The folder of iteration `index` in a campaign's `out_dir`: its run.csv,
// est.json and, when it designed, design.json.
std::string CampaignIterationDir(const std::string& out_dir, int index);

// The marginal information of the first `n` parameters (the bushings) with
// the others (an adopted effect's) as nuisance: the Schur complement
// I_cc - I_ce I_ee^+ I_ec, in the scaled parameters the designer uses.
Eigen::MatrixXd StiffnessInformation(const Eigen::MatrixXd& information, int n);

// How many of `it.estimate`'s parameters are the campaign's own (the
// stiffnesses, as many as the nominal model's beside an adopted effect);
// the effect's follow them.
size_t CampaignParameterCount(const CampaignIteration& it);

// Reads a campaign folder back: campaign.json (criterion; per iteration the
// index, logs, experiment, estimates with intervals and log10
// diag((J^T J)^-1), an adopted effect's after them and the nominal model's
// beside them, criterion of the data, whether it designed) and, for
// each iteration that designed, its design.json into `design`. Errors name
// the file and the field.
Status ReadCampaign(const std::string& out_dir, Criterion* criterion,
                    std::vector<CampaignIteration>* iterations);

// Runs the campaign in `out_dir` (iteration_K/run.csv, est.json,
// design.json per iteration); `iterations` receives every iteration as it
// completes (also on error, up to the failure).
Status RunCampaign(const KcrigConfig& config, const CampaignOptions& options,
                   const RigRunner& rig, const std::string& out_dir,
                   std::vector<CampaignIteration>* iterations);

// The per-iteration text: estimates with intervals, log10 diag((J^T J)^-1)
// bars (paper Figs. 4 and 6), the criterion before and after the design and
// the chosen excitation.
std::string CampaignIterationSummary(const CampaignIteration& iteration,
                                     Criterion criterion);

}  // namespace kcrig

#endif  // KCRIG_CAMPAIGN_CAMPAIGN_H_
