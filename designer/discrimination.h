// Optimal design for model discrimination: when two candidate models of the
// diagnosis explain the data about equally well, the experiment whose
// predicted responses differ the most between them, relative to the sensor
// noise, tells them apart. The criterion is the divergence
//   T(v) = sum_j sum_k ((y_a,k(t_j; v) - y_b,k(t_j; v)) / sigma_k)^2
// of the two fitted models over the design v = (phi, z_a) and the ramp's
// shape (ramp time, hold, return ramp), maximized with NLopt (BOBYQA) over
// (phi, z_a) for each shape. The models keep their fitted parameters (the
// divergence is not re-minimized over the rival's parameters, which would
// cost a fit per evaluation): a large T is necessary, not sufficient.
#ifndef KCRIG_DESIGNER_DISCRIMINATION_H_
#define KCRIG_DESIGNER_DISCRIMINATION_H_

#include <string>
#include <vector>

#include "base/status.h"
#include "diagnosis/diagnosis.h"
#include "estimator/effect_model.h"
#include "rt_core/model/model_config.h"

namespace kcrig {

// A ramp's shape: ramp time tf, hold, return ramp [s].
struct RampShape {
  double tf, hold, return_duration;
};

struct DiscriminationOptions {
  // Ramp shapes tried: ramp time tf, hold, return ramp [s]. Rate-dependent
  // effects differ from rate-independent ones between a fast and a slow
  // ramp and across a hold; the return ramp shows hysteresis loops.
  std::vector<RampShape> shapes = {
      {4.0, 0.0, 0.0}, {1.0, 0.0, 0.0}, {1.0, 1.0, 1.0}, {4.0, 1.0, 4.0}};
  // Criterion evaluations per shape (each simulates both models).
  int evaluations_per_shape = 24;
};

struct DiscriminatingDesign {
  std::string model_a, model_b;
  RampExcitation<double> excitation;  // the experiment to run
  double divergence = 0;              // T at the design
  int evaluations = 0;
};

// Designs the experiment that best tells `a` (at `values_a`) from `b` (at
// `values_b`) within the experiment's design bounds, with its Fmax, sample
// rate, integrator step and sensor sigmas.
Status DesignDiscriminatingExperiment(const EffectModel& a,
                                      const std::vector<double>& values_a,
                                      const EffectModel& b,
                                      const std::vector<double>& values_b,
                                      const ExperimentConfig& experiment,
                                      const DiscriminationOptions& options,
                                      DiscriminatingDesign* design);

// Two candidates of a diagnosis (`result.ranking`'s models `model_a` and
// `model_b`: an ambiguous pair, or a verdict of low confidence and its
// rival), as models at their fitted values, and the experiment that
// discriminates them.
Status DesignToTellApart(const KcrigConfig& config,
                         const DiagnosisOptions& options,
                         const DiagnosisResult& result,
                         const std::string& model_a, const std::string& model_b,
                         DiscriminatingDesign* design);

// The `kcrig run` / `kcrig simulate` options that perform `ramp`:
// "--phi 11.11 --z -0.500 --fmax 4000 --duration 1.00 --hold 0.00
// --return 0.00".
std::string RunOptions(const RampExcitation<double>& ramp);

// The design as a JSON object for diag.json (angles in deg, with the
// `kcrig run` / `kcrig simulate` options that perform it).
std::string DiscriminatingDesignToJson(const DiscriminatingDesign& design);

}  // namespace kcrig

#endif  // KCRIG_DESIGNER_DISCRIMINATION_H_
