// Small parsing helpers shared by the subcommands.
#ifndef KCRIG_APPS_CLI_UTIL_H_
#define KCRIG_APPS_CLI_UTIL_H_

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "CLI/CLI.hpp"
#include "base/status.h"
#include "cluster/input_mirror.h"
#include "estimator/experiment.h"
#include "rt_core/model/excitation.h"
#include "rt_core/model/model_config.h"

namespace kcrig {

// The whole text as a finite double.
bool ParseFiniteDouble(const std::string& text, double* value);

// CLI11 reads numbers with strtod/strtoll in base 0: "" as 0, "0x10" as 16,
// "-1" into an unsigned option as 2^64 - 1. This makes every numeric option
// of `app` and its subcommands take decimal text only (a float finite, an
// unsigned without a sign), one line naming the option otherwise.
void RequireDecimalNumbers(CLI::App* app);

// "NAME=VALUE" with a finite VALUE; `option` names the flag in errors.
Status ParseAssignment(const std::string& option, const std::string& text,
                       std::string* name, double* value);

// "NAME=VALUE" applied to the model parameter NAME (ListParameters' names:
// c_O1, d_P, k_spring, mass, O1.x, ...); `option` names the flag in errors.
Status ApplyParameterAssignment(const std::string& option,
                                const std::string& text,
                                SuspensionParameters<double>* model);

// "x,toe" -> channel indices into x, y, z, toe, camber, caster.
Status ParseChannels(const std::string& text, std::vector<int>* channels);

// "a,b,c" -> {"a", "b", "c"}; empty items are dropped.
std::vector<std::string> SplitList(const std::string& text,
                                   char separator = ',');

// The ramp options --phi DEG, --z M, --fmax N, --duration S shared by the
// commands that run one experiment; unset means the config's value.
struct ExcitationArgs {
  std::optional<double> phi_deg, z_a, fmax, duration, hold, return_duration;
};

void AddExcitationOptions(CLI::App* cmd, ExcitationArgs* args);

// The given values over the config's defaults; phi in rad. Unchecked.
RampExcitation<double> ResolveRamp(const ExcitationArgs& args,
                                   const ExperimentConfig& experiment);

// How every command ends on an error: one line "kcrig COMMAND: message" on
// stderr, and exit status 1.
class CommandError {
 public:
  explicit CommandError(std::string command) : command_(std::move(command)) {}
  int operator()(const Status& status) const;

 private:
  std::string command_;
};

// Before any work: the file `out` (given with `option`; "" for none) may be
// written (base's CheckReplaceable) and is none of `inputs`, nor a run
// log's sidecar among them: writing it would destroy what is read.
Status CheckOutput(const std::string& option, const std::string& out,
                   const std::vector<std::string>& inputs);

// The DBC of the config's rig.yaml (can.dbc), which decodes CAN bus logs.
Status ConfiguredDbc(const KcrigConfig& config, std::string* dbc_file);

// The logs as experiments (estimator's LoadExperiments); a CAN bus log is
// decoded with the DBC of the config's rig.yaml.
Status LoadLogs(const std::vector<std::string>& paths,
                const KcrigConfig& config,
                std::vector<Experiment>* experiments);

// --ramp's help: a planned ramp of `kcrig isolability` and `kcrig design
// --isolate`.
inline constexpr char kRampHelp[] =
    "Planned ramp PHI_DEG,Z_M[,TF_S[,HOLD_S[,RETURN_S]]] with the config's "
    "Fmax (repeatable; none and no --log: the config's experiment)";

// "PHI_DEG,Z_M[,TF_S[,HOLD_S[,RETURN_S]]]" (--ramp): a planned ramp with
// the config's Fmax, within its design bounds; the ramp time defaults to
// the config's.
Status ParsePlannedRamp(const std::string& text, const ExperimentConfig& config,
                        RampExcitation<double>* ramp);

// A plan of experiments: the logs, then the planned ramps; the config's
// own experiment when neither is given.
Status LoadPlan(const std::vector<std::string>& logs,
                const std::vector<std::string>& ramps,
                const KcrigConfig& config, std::vector<Experiment>* plan);

// A plan's command inputs: the config of `config_dir`, `out` checked
// (CheckOutput's --out), then LoadPlan.
Status LoadPlanInputs(const std::string& config_dir, const std::string& out,
                      const std::vector<std::string>& logs,
                      const std::vector<std::string>& ramps,
                      KcrigConfig* config, std::vector<Experiment>* plan);

// Under MPI rank 0 alone reads the inputs (cluster/input_mirror.h): the
// config folder (as LoadConfig resolves "") and the logs with their
// sidecars; on the other ranks the paths then name their copies.
Status MirrorConfig(InputMirror* mirror, std::string* config_dir);
Status MirrorLogs(InputMirror* mirror, std::vector<std::string>* logs);

}  // namespace kcrig

#endif  // KCRIG_APPS_CLI_UTIL_H_
