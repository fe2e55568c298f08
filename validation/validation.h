// `kcrig validate`: how well does kcrig diagnose *this* configuration? Blind
// cases (blind_case.h) are run back to back on the embedded SIL rig with
// the case's truth as its plant (stepped finer than the model, as a rig is
// continuous; the configured sensor noise; the rig's phases, actuator, load
// cell and memory from run to run), diagnosed exactly as `kcrig diagnose` does
// on logs whose truth is stripped, and only then compared with their truth:
// the confusion matrix, the detection rate against the effect's size in
// noise units (a power curve per class), the false-alarm rate, the gap
// closed, and the confident wrong answers.
//
// The size of an effect "in the residual" is the RMS, in noise units, of
// the nominal model's fitted residual on the same training logs run
// without noise (never shown to the diagnosis).
#ifndef KCRIG_VALIDATION_VALIDATION_H_
#define KCRIG_VALIDATION_VALIDATION_H_

#include <cstdint>
#include <string>
#include <vector>

#include "base/status.h"
#include "diagnosis/diagnosis.h"
#include "emulator/plant_config.h"
#include "estimator/experiment.h"
#include "hil/rig_config.h"
#include "rt_core/model/model_config.h"
#include "validation/blind_case.h"

namespace kcrig {

struct ValidationOptions {
  int cases = 40;
  std::uint64_t seed = 1;
  // The truths cycled through (BlindCaseClasses() names; empty: all).
  std::vector<std::string> classes;
  // The experiments every case runs (empty: each case draws its own).
  BlindTestPlan plan;
  // The rig's integration step [s]: a rig is continuous, so the logs come
  // from a plant stepped ten times finer than the model (1e-3 s).
  double plant_step = 1e-4;
  // As `kcrig diagnose` runs (its callback can stop a case).
  DiagnosisOptions diagnosis;
  // The rig the cases run on, which LoadValidationRig must load before a
  // case runs: plant.yaml's rig stepped at plant_step, and rig.yaml's loop and
  // limits with the error detector opened — it guards a rig against a model far
  // from it, which a blind case is on purpose; the force, rate and travel
  // limits and the watchdog stay as configured.
  PlantConfig plant;
  RigConfig rig;
};

// Loads the rig of `options` from the configuration (plant.yaml, rig.yaml)
// and checks the plan's ramps (read from `plan_file`; none when empty)
// against its limits: one line naming the file and the ramp
// (training[i], holdout[i]).
Status LoadValidationRig(const KcrigConfig& config,
                         const std::string& plan_file,
                         ValidationOptions* options);

// The case's ramps within the rig's limits (force, force rate): one line
// naming the case and the ramp otherwise.
Status CheckBlindCaseOnRig(const KcrigConfig& config,
                           const ValidationOptions& options,
                           const BlindCase& c);

// Runs case `index` on the SIL rig, diagnoses and scores it; `outcome` is
// its JSON object (the case's truth, designs, size, and the diagnosis' verdict,
// model, confidence, components, ambiguity, gap closed and, for a wrong
// parameter, whether its true value lies in the 95 % interval).
Status RunValidationCase(const KcrigConfig& config,
                         const ValidationOptions& options, int index,
                         std::string* outcome);

// validate.json from the outcomes of cases 0 .. n-1 (in order): the
// options, the figures and every case. Byte-identical for the same
// outcomes (no timings, no host names).
std::string ValidationToJson(const KcrigConfig& config,
                             const ValidationOptions& options,
                             const std::vector<std::string>& outcomes);

// The columns of the confusion matrix in order: `none`, the classes, `pair`
// (two effects named), `unexplained`. Its rows are BlindCaseClasses().
const std::vector<std::string>& ConfusionColumns();

// The terminal summary of validate.json's figures: the confusion matrix,
// the power curve and the rates, in one screen.
std::string ValidationSummary(const std::string& validation_json);

// sigma_hat of the nominal model (bushings fitted) on `experiments`: the
// size of an effect in noise units when they are noise-free.
Status NominalFitSigmaHat(const KcrigConfig& config,
                          const std::vector<Experiment>& experiments,
                          double* sigma_hat);

}  // namespace kcrig

#endif  // KCRIG_VALIDATION_VALIDATION_H_
