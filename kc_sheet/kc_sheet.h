// The K&C sheet of a set of rig runs: the figures a K&C engineer judges a
// suspension by, measured and modelled side by side.
//
// - Per run and response channel, the compliance gradient against the force
//   along the excitation (the component of the load cell's force along the
//   ramp's direction): one line per branch (rising: the ramp -Fmax ->
//   +Fmax; falling: the return +Fmax -> -Fmax) and a common gradient with one
//   intercept per branch, whose difference is the loop width at zero force
//   (the hysteresis); and the loop's area, -closed integral of r df (the
//   energy a dissipative loop takes per cycle, > 0).
// - Per acting height at which runs in at least two directions were made,
//   the gradients per force component (Fx, Fy), from all those runs
//   together: lateral force steer and camber, lateral and longitudinal
//   compliance, longitudinal force steer.
// - The model's figures from the same computation on its simulation of the
//   same runs (the same forces, the same samples), their difference in
//   combined standard errors, and the model's analytic static compliance.
//
// Standard errors. `standard_error` is ordinary least squares' (from the
// residuals of the line, what NumPy's or MATLAB's regression reports).
// `noise_standard_error` is the sensor noise's part alone (sigma of the
// channel times sqrt((X^T X)^-1)): the uncertainty of a measured figure as
// an estimate of what the rig would give without noise. A model/rig
// difference is judged against the noise's part of the measurement and
// the model's parameter uncertainty (carried by central differences): the
// misfit of a straight line to a curved response is common to both and does
// not make their difference uncertain.
#ifndef KCRIG_KC_SHEET_KC_SHEET_H_
#define KCRIG_KC_SHEET_KC_SHEET_H_

#include <array>
#include <limits>
#include <string>
#include <vector>

#include "Eigen/Core"
#include "base/status.h"
#include "estimator/experiment.h"
#include "records/run_log.h"
#include "rt_core/model/static_compliance.h"
#include "rt_core/model/suspension_parameters.h"

namespace kcrig {

// The axes the sheet reports in. ISO 8855 is the logs' frame (x forward,
// y left, z up); SAE J670 has y right and z down, which flips y, z, Fy,
// Fz, My, Mz and the rotations about y and z (caster, toe); x, Fx, Mx and
// camber (about x) keep their signs.
enum class SignConvention { kIso8855, kSae };

struct KcSheetOptions {
  SignConvention convention = SignConvention::kIso8855;
  // A model/rig difference beyond this many combined standard errors flags
  // the figure (and its channel) as differing.
  double flag_z = 3.0;
  // Directions of a component fit: the spread of the forces (the force
  // block of the normal matrix, intercepts taken out) must be better
  // conditioned than this: 1e3 is runs at least ~4 deg apart.
  double max_component_condition = 1e3;
  // Runs whose acting heights differ by less than this [m] share a
  // component fit.
  double same_height = 1e-3;
  // The height of the contact patch below the wheel centre [m], for the
  // model's contact-patch compliance; NaN: not reported.
  double contact_patch_z = std::numeric_limits<double>::quiet_NaN();
};

// The model a sheet compares the rig with: the suspension `parameters` (an
// estimate applied) plus `effects` at `effect_values` (EffectModel's effect
// parameters, in its order), simulated at `integrator_step`.
struct KcModel {
  std::string name = "nominal";
  SuspensionParameters<double> parameters;
  std::vector<std::string> effects;
  std::vector<double> effect_values;
  // The covariance [physical units] of the parameters named `uncertain`
  // (ListParameters' names, or "effect.parameter"); empty: the model's
  // figures are taken as exact.
  std::vector<std::string> uncertain;
  Eigen::MatrixXd covariance;
  double integrator_step = 0;
};

// The model of an estimate: `names` (ListParameters' names, and
// "effect.parameter" for the effect of an adopted model, as est.json and
// campaign.json name them) at `values` over `nominal`, with their
// `covariance` (physical units; empty or not finite: none). Errors name the
// unknown parameter.
Status KcModelOfEstimate(const SuspensionParameters<double>& nominal,
                         const std::vector<std::string>& names,
                         const std::vector<double>& values,
                         const Eigen::MatrixXd& covariance,
                         double integrator_step, KcModel* model);

// One straight line r = intercept + slope f.
struct LineFit {
  double slope = 0;      // [m/N or rad/N]
  double intercept = 0;  // [m or rad]
  double standard_error = 0;
  double noise_standard_error = 0;
  int samples = 0;
  double residual_rms = 0;  // [m or rad]
};

// A figure with its standard errors (see the file comment).
struct Figure {
  double value = 0;
  double standard_error = 0;
  double noise_standard_error = 0;
};

struct ChannelFigures {
  // Common gradient of both branches, with one intercept per branch.
  Figure gradient;  // [m/N or rad/N]
  LineFit rising, falling;
  // Falling minus rising branch at zero force [m or rad]; 0 without a
  // falling branch.
  Figure loop_width;
  double loop_area = 0;  // -closed integral of r df [N m or N rad]
};

// A model figure against the rig's.
struct Comparison {
  double difference = 0;  // model - rig
  double z = 0;           // in combined standard errors
  bool differs = false;   // |z| > KcSheetOptions::flag_z
};

struct RunSheet {
  std::string source;
  double phi = 0;   // [rad]
  double z_a = 0;   // [m]
  double fmax = 0;  // [N]
  bool has_falling = false;
  std::array<ChannelFigures, 6> rig;
  // With a model:
  std::array<ChannelFigures, 6> model;
  // The model's parameter uncertainty in its gradient and loop width.
  std::array<double, 6> model_gradient_se{};
  std::array<double, 6> model_loop_width_se{};
  std::array<Comparison, 6> gradient_difference;
  std::array<Comparison, 6> loop_width_difference;
  // d(channel)/d(force along the excitation) of the model's static
  // compliance at the run's acting height.
  std::array<double, 6> static_gradient{};
  // For plotting the loops: the force along the excitation per log sample
  // [N], the samples of each branch (rising, falling; indices into the
  // log) and the model's reading per log sample (empty without a model).
  std::vector<double> force_along;
  std::array<std::vector<int>, 2> branches;
  std::vector<Vec6<double>> model_response;
};

// Gradients per force component from runs in several directions at one
// acting height. Columns Fx, Fy; rows the six channels.
struct ComponentSheet {
  double z_a = 0;  // [m]
  std::vector<std::string> sources;
  Eigen::Matrix<double, 6, 2> rig = Eigen::Matrix<double, 6, 2>::Zero();
  Eigen::Matrix<double, 6, 2> rig_se = Eigen::Matrix<double, 6, 2>::Zero();
  Eigen::Matrix<double, 6, 2> rig_noise_se =
      Eigen::Matrix<double, 6, 2>::Zero();
  Eigen::Matrix<double, 6, 2> model = Eigen::Matrix<double, 6, 2>::Zero();
  Eigen::Matrix<double, 6, 2> model_se = Eigen::Matrix<double, 6, 2>::Zero();
  Eigen::Matrix<double, 6, 2> z = Eigen::Matrix<double, 6, 2>::Zero();
  // The model's static compliance at this height, same layout.
  Eigen::Matrix<double, 6, 2> static_compliance =
      Eigen::Matrix<double, 6, 2>::Zero();
};

// A standard K&C figure in display units: at an acting height, the rig's
// and the model's component gradients (a component sheet's: the model with
// its effects, on the same runs) and the suspension's static compliance;
// at the wheel centre and the contact patch, the static compliance alone.
// The static figure is the suspension's: without the rig's own compliance
// or dynamics, which the measured one includes.
struct NamedFigure {
  std::string name;   // "lateral force steer", ...
  std::string place;  // "wheel centre", "contact patch", "z_a -0.450 m"
  std::string unit;   // "deg/kN", "mm/kN", "deg/100 N m"
  bool has_rig = false;
  double rig = 0, rig_standard_error = 0;
  bool has_model = false;
  double model = 0, model_standard_error = 0;
  double z = 0;  // model - rig in combined standard errors
  double model_static = 0;
};

struct KcSheet {
  SignConvention convention = SignConvention::kIso8855;
  double flag_z = 3.0;  // KcSheetOptions::flag_z
  bool has_model = false;
  std::string model_name;
  std::vector<RunSheet> runs;
  std::vector<ComponentSheet> components;
  // The model's static compliance (has_model only).
  StaticCompliance compliance;
  bool has_contact_patch = false;
  // Channels with a differing gradient or loop width in some run.
  std::array<bool, 6> channel_differs{};
  std::vector<NamedFigure> named;
};

// One run of the sheet: its log (for the phases and the excitation) and the
// experiment made of it (forces, which samples were measured, sigmas).
struct KcRun {
  const RunLog* log = nullptr;
  const Experiment* experiment = nullptr;
};

// The sheet of `runs`, compared with `model` when it is not null.
Status ComputeKcSheet(const std::vector<KcRun>& runs, const KcModel* model,
                      const KcSheetOptions& options, KcSheet* sheet);

}  // namespace kcrig

#endif  // KCRIG_KC_SHEET_KC_SHEET_H_
