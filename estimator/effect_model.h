// A candidate model of the sim-to-real diagnosis: the nominal suspension
// model plus zero, one or two of the unmodelled effects of
// rt_core/model/plant_effects.h, with the five bushing stiffnesses and the
// effects' parameters fitted jointly to logged experiments. The model is the
// emulator's own plant (BasicRigPlant) driven by the logged load-cell
// force, so a candidate is exactly the physics the software rig runs; the
// sensitivities are exact (the plant's tangent-linear step, equal to
// ceres::Jet through the whole trajectory).
//
// Parameters are fitted in scaled form theta: a bushing stiffness is
// nominal * theta, an effect parameter base + scale * theta (scale a typical
// magnitude, so every theta is of order one).
#ifndef KCRIG_ESTIMATOR_EFFECT_MODEL_H_
#define KCRIG_ESTIMATOR_EFFECT_MODEL_H_

#include <string>
#include <vector>

#include "Eigen/Core"
#include "base/iteration_callback.h"
#include "base/status.h"
#include "estimator/adequacy.h"
#include "estimator/estimator.h"
#include "estimator/experiment.h"
#include "rt_core/model/plant_effects.h"
#include "rt_core/model/suspension_parameters.h"

namespace kcrig {

// The class of a wrong "known" parameter: a parameter the nominal model
// holds fixed (FreeableModelParameters) freed and fitted with the
// stiffnesses, named "model_parameter@k_spring", "model_parameter@O1" (the
// hard point O1: its three coordinates O1.x, O1.y, O1.z) or, asked for by
// hand, "model_parameter@O1.z" (one coordinate).
inline constexpr char kModelParameter[] = "model_parameter";

// What the screening frees: the strut's spring and damper rates, the
// carrier's mass and principal inertias and every hard point, whole
// (ListParameters' names, a point's coordinates as the point; not the
// bushing stiffnesses, which every candidate fits, nor the bushing
// damping, which bushing_damping places on the bushings).
std::vector<std::string> FreeableModelParameters();

// "model_parameter@k_spring": the candidate that frees `parameter`.
inline std::string FreedModelName(const std::string& parameter) {
  return kModelParameter + std::string("@") + parameter;
}

// Sets each freed model parameter among `names` (est.json's and a fit's
// parameter names, "model_parameter.k_spring") to its value in `model`:
// the model a fit with freed parameters describes.
void ApplyFreedParameters(const std::vector<std::string>& names,
                          const std::vector<double>& values,
                          SuspensionParameters<double>* model);

struct EffectParameter {
  std::string effect;  // "" for a bushing stiffness
  std::string name;    // "c_O1", "force", "dead_time", ...
  std::string unit;
  double base = 0;              // physical value = base + scale * theta
  double scale = 1;             // > 0
  double lower = 0, upper = 0;  // physical bounds of the fit
  double initial = 0;           // physical start of the fit
  // Further starts, in order, for effects whose fit from a small effect can
  // end in a local minimum when the true effect is large (a bushing's is
  // its configured stiffness). A model has as many starts as its longest
  // list allows; a shorter list repeats its last entry.
  std::vector<double> later_starts;
  // A shape of the effect, not its size (the Dahl loop's sigma, which a
  // sharp loop legitimately takes to its bound): exempt from the far-bound
  // check (CandidateScore::at_far_bound).
  bool shape = false;

  // As fits and est.json name it: "c_O1", "hysteresis.force",
  // "model_parameter.k_spring".
  std::string FullName() const {
    return effect.empty() ? name : effect + "." + name;
  }
};

// Most parameters of one candidate: five bushings plus two effects (the
// sensor offset has seven, the stiffening three: 15), or a sensor error on
// two channels (eight) with a small effect.
inline constexpr int kMaxEffectModelParameters = 16;

class EffectModel {
 public:
  EffectModel() = default;

  // `effects`: distinct names of kEffectNames, at most two; empty is the
  // nominal model. A bushing effect may be placed on components,
  // "hysteresis@bushing:V1" or "bushing_damping@bushing:O1+bushing:O2"
  // (plant_effects.h: `at`); unplaced, it acts in every bushing. Any number
  // of model parameters may be freed besides ("model_parameter@k_spring"),
  // within kMaxEffectModelParameters in all. The bushing stiffnesses are
  // bounded by [lower_scale, upper_scale] x their `nominal` values.
  static Status Create(const SuspensionParameters<double>& nominal,
                       const std::vector<std::string>& effects,
                       double lower_scale, double upper_scale,
                       EffectModel* model);

  // Create for a model's Name(): "nominal", "hysteresis",
  // "hysteresis+actuator_lag", "hysteresis@bushing:O1+bushing:V1+
  // actuator_lag" (as diag.json and a diagnosis name them).
  static Status CreateNamed(const SuspensionParameters<double>& nominal,
                            const std::string& name, double lower_scale,
                            double upper_scale, EffectModel* model);

  // "nominal", "hysteresis", "hysteresis+actuator_lag",
  // "hysteresis@bushing:V1".
  std::string Name() const;
  // Each effect as a single candidate names it ("hysteresis@bushing:V1",
  // "model_parameter@k_spring"); Name() joins them.
  std::vector<std::string> EffectNames() const;
  // The effects' classes (names of kEffectNames, kModelParameter), where
  // each acts (every bushing unless placed; meaningful for the bushing
  // effects) and the parameter each frees ("" but for model_parameter).
  const std::vector<std::string>& effects() const { return effects_; }
  const std::vector<BushingSet>& placements() const { return placements_; }
  const std::vector<std::string>& targets() const { return targets_; }
  const std::vector<EffectParameter>& parameters() const { return parameters_; }
  int num_parameters() const { return static_cast<int>(parameters_.size()); }
  // The longest dead time the bounds allow [s] (sizes the delay line).
  double max_dead_time() const { return max_dead_time_; }
  // A start for this model from `values` of `other` (physical, one per
  // its parameter): each parameter of the same full name takes the other's
  // value, the rest their `initial` (a placed effect from its global fit).
  std::vector<double> StartFrom(const EffectModel& other,
                                const std::vector<double>& values) const;
  // 1 + the longest list of later starts of its parameters.
  int num_starts() const;
  // Start `k` >= 1 (physical values, one per parameter): each parameter's
  // later_starts[k - 1], or its last, or its `initial` when it has none.
  std::vector<double> LaterStart(int k) const;

  double ToPhysical(int i, double theta) const {
    return parameters_[i].base + parameters_[i].scale * theta;
  }
  double ToTheta(int i, double physical) const {
    return (physical - parameters_[i].base) / parameters_[i].scale;
  }

  // The plant's parameters and effects at scaled values `theta`.
  template <typename T>
  void Build(const T* theta, SuspensionParameters<T>* parameters,
             BasicPlantEffects<T>* effects) const;

 private:
  SuspensionParameters<double> nominal_;
  std::vector<std::string> effects_;
  std::vector<BushingSet> placements_;
  std::vector<std::string> targets_;
  // Where rig_compliance and actuator_lag act (their targets, parsed once).
  FixtureAxes fixture_axes_ = kTranslationalAxes;
  ActuatorAxes actuator_axes_ = kEveryActuator;
  std::vector<EffectParameter> parameters_;
  double max_dead_time_ = 0;
};

// The effects of a model's name (EffectModel::Name(); "nominal": none),
// where each acts and, with `targets`, the parameter each frees, without
// checking the classes (Create does).
Status ParseModelName(const std::string& name,
                      std::vector<std::string>* effects,
                      std::vector<BushingSet>* placements,
                      std::vector<std::string>* targets = nullptr);

// The components an effect class can be placed on, in the vocabulary's
// order: the bushings for the bushing effects, the fixture axes for
// rig_compliance, the actuator axes for actuator_lag, the sensor channels
// for sensor_offset; none for model_parameter.
std::vector<std::string> PlaceableComponents(std::string_view effect);

// Whether `logs` load `component`: a fixture or actuator axis is loaded by
// its force (a fixture rotation by the moment about the wheel centre: the
// force across it at a nonzero acting height) beyond 1 % of the largest
// force on the wheel in some log. An effect on an axis no log loads shows
// nowhere, so its placement there could only tie with the placement
// without it. Bushings and sensor channels are always loaded.
bool LoadsComponent(const std::vector<Experiment>& logs,
                    std::string_view component);

// The components a model acts on, each once: a placed effect's own, an
// unplaced one's where its global form acts (every bushing; the
// translational fixture axes; every actuator axis; every sensor channel),
// in the vocabulary's order (bushings, fixture, actuators, sensors), then a
// freed parameter's component (ComponentOfParameter). Empty for the nominal
// model or a name that does not parse.
std::vector<std::string> ModelComponents(const std::string& name);

// What the sensors of the candidate read for one experiment at the physical
// parameter values `values` (one per EffectModel::parameters()): the plant
// settled under the first logged force, then stepped through the logged
// forces. Errors when the model cannot be evaluated there (diverges).
Status SimulateEffectModel(const EffectModel& model,
                           const std::vector<double>& values,
                           const Experiment& experiment, double integrator_step,
                           std::vector<Vec6<double>>* sensed);

struct EffectFitOptions {
  // Levenberg-Marquardt limits. A diagnosis compares costs between
  // candidates: a relative change of 1e-9 is far below any difference that
  // matters (one unit of chi-square in 10^4 residuals is 1e-4).
  int max_iterations = 60;
  double function_tolerance = 1e-7;
  double parameter_tolerance = 1e-8;
  // Options of the uncertainty analysis (rank and identifiability
  // thresholds) as for the nominal estimate; its callback is not used.
  EstimatorOptions uncertainty;
  // Asked after every Levenberg-Marquardt iteration ("fitting the <model>
  // model: iteration k"); kAbort stops the fit with Interrupted().
  // Optional.
  IterationCallback callback;
  // Whether each fit estimates its own discretisation error (Richardson's
  // estimate, largest channel RMS [sigma], in the adequacy) and the bias it
  // leaves in the parameters, which widens their intervals
  // (AddDiscretisationBias). false: neither (a diagnosis compares its
  // candidates at one step and estimates the error itself).
  bool estimate_discretisation = false;
  // A fit whose error exceeds max_discretisation [sigma] is fitted again at
  // half the step, from its values, up to max_step_halvings times: whether
  // the model explains the logs, and where its intervals lie, are then the
  // model's answers, not its integrator's (a 1 ms model with an actuator
  // lag errs by a few tenths of sigma on a fast designed ramp, which
  // Ljung-Box sees, and its stiffnesses move by more than their standard
  // errors). The error and bias are those at the step reached.
  int max_step_halvings = 0;
  double max_discretisation = 0.03;
};

struct EffectFit {
  std::string model;  // EffectModel::Name()
  // Per parameter (the bushings, then each effect's): value, standard
  // error, 95 % interval, in physical units; covariance, sigma_hat, cost,
  // iterations, convergence (EstimationResult's meaning; `nominal` holds
  // the parameter's scale). result.integrator_step is the step the fit was
  // made at; with estimate_discretisation its discretisation error there is
  // result.adequacy.discretisation, and the bias it leaves in each
  // parameter widens the intervals (AddDiscretisationBias).
  EstimationResult result;
  std::vector<double> values;  // physical, one per parameter
};

// Fits all parameters of `model` to `experiments` jointly, from `initial`
// (physical values, one per parameter; empty: each parameter's `initial`).
// Single-threaded: a diagnosis runs candidates side by side.
Status FitEffectModel(const EffectModel& model,
                      const std::vector<Experiment>& experiments,
                      const std::vector<double>& initial,
                      const EffectFitOptions& options, double integrator_step,
                      EffectFit* fit);

// A model parameter's promise as a candidate: the chi-square that freeing
// it removes from a fit's training residual, to first order (one
// Gauss-Newton step with the stiffnesses), for the parameters it frees
// (three for a hard point).
struct ParameterLead {
  std::string name;
  double chi2_drop = 0;
  int freed = 1;
};

// Screens `candidates` (of FreeableModelParameters, or coordinates; a rate
// configured zero is left out: it cannot be freed) at a fit of the nominal
// model, `stiffness` (physical, the five bushings): the exact weighted
// Jacobian of its residual on `experiments` by the stiffnesses and the
// names (as many names per trajectory as one model frees, the trajectories
// on `num_threads` threads); each name's columns, made orthogonal to the
// stiffnesses', span what it can remove of the residual. Largest drop
// first.
Status ScreenModelParameters(const SuspensionParameters<double>& nominal,
                             const std::vector<double>& stiffness,
                             const std::vector<std::string>& candidates,
                             const std::vector<Experiment>& experiments,
                             double integrator_step, int num_threads,
                             std::vector<ParameterLead>* leads);

// Weighted residuals (sensed - measured) / sigma per sample (zero where
// not observed) of `model` at `values` on one experiment.
Status WeightedResiduals(const EffectModel& model,
                         const std::vector<double>& values, const Experiment& e,
                         double step, std::vector<Vec6<double>>* weighted);
// The same weighting of readings `sensed` already simulated on `e`.
std::vector<Vec6<double>> WeightedResidualsOf(
    const Experiment& e, const std::vector<Vec6<double>>& sensed);

// The model's own discretisation error at `values` on each experiment,
// weighted as WeightedResiduals: Richardson's estimate 2 (y_h - y_h/2) of
// the first-order scheme, from one more simulation at half the step.
Status DiscretisationError(const EffectModel& model,
                           const std::vector<double>& values,
                           const std::vector<Experiment>& experiments,
                           double step,
                           std::vector<std::vector<Vec6<double>>>* error);

// Predicts `experiments` (given at `integrator_step`), which `fit` (of
// `model`) has not seen: the prediction's adequacy against the sensor noise
// over all six channels, the fit's own uncertainty accounted for
// (AssessPredictionResiduals), at the fit's step (EffectFit::
// integrator_step, a power-of-two fraction of the given one) or its
// continuous-time limit (BetterOfStepAndLimit).
Status PredictEffectModel(const EffectModel& model, const EffectFit& fit,
                          const std::vector<Experiment>& experiments,
                          double integrator_step,
                          const AdequacyOptions& options, Adequacy* prediction);

// The weighted residuals of `experiments` stacked (WeightedResiduals'
// order) and their exact Jacobian by the scaled parameters theta, at
// `values` (physical; clamped into the box: a value on its bound may round
// just outside it). `theta` gets the clamped point.
Status WeightedJacobian(const EffectModel& model,
                        const std::vector<double>& values,
                        const std::vector<Experiment>& experiments,
                        double integrator_step, std::vector<double>* theta,
                        Eigen::MatrixXd* jacobian, Eigen::VectorXd* residuals);

// One Gauss-Newton step from `values` (a fit to more data) on
// `experiments`, within the parameter bounds: the standard one-step
// approximation of a refit to a subset of the data, at the cost of one
// trajectory with sensitivities per experiment instead of a whole fit
// (cross-validation folds).
Status RefitOneStep(const EffectModel& model, const std::vector<double>& values,
                    const std::vector<Experiment>& experiments,
                    double integrator_step, std::vector<double>* refit);

}  // namespace kcrig

#endif  // KCRIG_ESTIMATOR_EFFECT_MODEL_H_
