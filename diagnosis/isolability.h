// Which faults a set of experiments can tell apart, before they are run:
// the isolability matrix of the diagnosis' candidates (an effect on one
// component, a freed model parameter) on planned or logged experiments.
//
// A candidate's signature is what it does to the weighted sensor readings
// beyond what the five bushing stiffnesses (which every candidate refits)
// absorb: the columns of its exact Jacobian by its scaled parameters, at
// the start of its fit, projected off the stiffnesses' columns. Candidate
// j mimics candidate i to the extent that its own columns (with the
// stiffnesses) reproduce i's signature. left(i, j) is the share of i's
// signature that j leaves, for a fault drawn isotropically in i's scaled
// parameters (each of order one, effect_model.h):
//   left(i, j) = ||P_perp[K, S_j] S_i||_F^2 / ||P_perp[K] S_i||_F^2,
// a first-order figure in [0, 1], independent of the fault's size. The
// diagnosis tells i from j when j, fitted to i's data, leaves at least
// DiagnosisOptions::min_gap_margin of the gap (verdict.h: ClearlyBetter):
// the pair is separable when both left(i, j) and left(j, i) reach it.
// (Structural isolability, as the Linkoping fault-diagnosis toolbox
// computes it for residual generators, here for the rig's experiments and
// the diagnosis' own fits; a noise-free, first-order figure: an effect too
// small to be seen at all is not told from anything, whatever the matrix.)
#ifndef KCRIG_DIAGNOSIS_ISOLABILITY_H_
#define KCRIG_DIAGNOSIS_ISOLABILITY_H_

#include <string>
#include <vector>

#include "Eigen/Core"
#include "base/iteration_callback.h"
#include "base/parallel_for.h"
#include "base/status.h"
#include "estimator/effect_model.h"
#include "estimator/experiment.h"
#include "rt_core/model/suspension_parameters.h"

namespace kcrig {

struct IsolabilityOptions {
  // The candidates (placed effects, model_parameter@NAME); empty:
  // IsolabilityCandidates().
  std::vector<std::string> candidates;
  // The share of a candidate's signature a rival must leave for the
  // diagnosis to tell them apart: DiagnosisOptions::min_gap_margin.
  double min_share_left = 0.2;
  // Candidates' Jacobians are computed on this many threads.
  int num_threads = kDefaultThreads;
  // Asked after each candidate's Jacobian; kAbort stops with Interrupted().
  // Optional.
  IterationCallback callback;
};

struct Isolability {
  std::vector<std::string> candidates;
  // Whether the experiments see the candidate at all beyond the
  // stiffnesses (an effect on an axis no experiment loads does not show).
  std::vector<bool> visible;
  // left(i, j) as above; left(i, i) = 0; NaN where i or j is not visible.
  Eigen::MatrixXd left;
  double min_share_left = 0.2;

  // Both ways: i's data are not explained by j nor j's by i. False when
  // either is not visible.
  bool Separable(int i, int j) const;
  // The pairs (i < j) of visible candidates that are not separable.
  std::vector<std::pair<int, int>> Ties() const;
  // The smallest min(left(i, j), left(j, i)) over pairs of visible
  // candidates (1 with fewer than two).
  double SmallestSeparation() const;
};

// The matrix built up one experiment at a time: a plan's logs once, then
// each trial design of the next experiment on a copy (what `kcrig design
// --isolate` searches over).
class IsolabilityAnalysis {
 public:
  // Columns of a candidate's signature in the stacked Jacobian.
  struct Block {
    int first = 0;
    int count = 0;
  };

  // For `options.candidates` on `nominal` at `integrator_step`; errors
  // name a candidate that cannot be created.
  static Status Create(const SuspensionParameters<double>& nominal,
                       double integrator_step,
                       const IsolabilityOptions& options,
                       IsolabilityAnalysis* analysis);
  // Adds one experiment's sensitivities (planned or logged); errors name
  // it.
  Status Add(const Experiment& experiment);
  int num_experiments() const { return num_experiments_; }
  // The matrix of the experiments added so far.
  Isolability Matrix() const;

 private:
  std::vector<std::string> candidates_;
  IsolabilityOptions options_;
  double step_ = 0;
  std::vector<EffectModel> models_;
  std::vector<Block> blocks_;
  EffectModel nominal_model_;
  // The R factor of the stacked weighted Jacobian: the stiffnesses'
  // columns, then each candidate's (blocks_).
  Eigen::MatrixXd triangle_;
  int num_experiments_ = 0;
};

// Every single-component placement of every placeable effect
// (PlaceableComponents) and every freeable model parameter
// (FreeableModelParameters, a hard point whole) that can be freed on
// `nominal` (a rate configured zero cannot).
std::vector<std::string> IsolabilityCandidates(
    const SuspensionParameters<double>& nominal);

// The matrix of `options.candidates` on `experiments` (planned:
// PlannedExperiment, or logged) at `integrator_step`. Errors name the
// candidate or experiment that cannot be evaluated.
Status ComputeIsolability(const SuspensionParameters<double>& nominal,
                          const std::vector<Experiment>& experiments,
                          double integrator_step,
                          const IsolabilityOptions& options,
                          Isolability* isolability);

// The matrix as a JSON object ("candidates", "visible", "left" with null
// where undefined, "min_share_left", "ties", "smallest_separation").
std::string IsolabilityToJson(const Isolability& isolability);

// For the terminal: how many pairs are separable, the ties (each pair once,
// one line per candidate: "bushing_damping@bushing:V2 ~ hysteresis@
// bushing:V2 (0 %), actuator_lag@actuator:y (13 %)", the smaller of the
// two shares left) and the candidates the experiments do not see.
std::string IsolabilitySummary(const Isolability& isolability);

}  // namespace kcrig

#endif  // KCRIG_DIAGNOSIS_ISOLABILITY_H_
