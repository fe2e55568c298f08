#include "apps/sil_rig_options.h"

#include <cstdio>
#include <cstdlib>

#include "apps/cli_util.h"

namespace kcrig {

void AddSilRigOptions(CLI::App* cmd, SilRigArgs* args, bool with_faults) {
  cmd->add_option_function<std::uint64_t>(
      "--seed", [args](const std::uint64_t& s) { args->seed = s; },
      "Sensor-noise seed of the embedded rig (default: plant.yaml)");
  cmd->add_option(
      "--plant-effect", args->plant_effects,
      "Unmodelled effect of the embedded rig's plant, NAME[:k=v,...] "
      "(repeatable; the syntax of simulate --effect; --rig sim only): "
      "rehearse the model checks without a rig");
  cmd->add_option(
      "--plant-set", args->plant_sets,
      "A parameter of the embedded rig's plant that differs from the "
      "configured model, NAME=VALUE in SI (repeatable; the syntax of "
      "simulate --set; --rig sim only): rehearse a wrong \"known\" parameter");
  cmd->add_option_function<double>(
         "--pace", [args](const double& pace) { args->pace = pace; },
         "Run the embedded rig's virtual clock at most this many times real "
         "time (0: as fast as the CPU allows, the default; 1 with --console, "
         "so that the run can be watched). The logs are the same either way")
      ->check([](const std::string& text) {
        // Slower than 1/10 of real time a cycle of rig.yaml's longest
        // period (0.1 s) would outlast the pace's restart (1.5 s ahead);
        // 0 is unpaced.
        const double pace = std::strtod(text.c_str(), nullptr);
        return pace == 0 || (pace >= 0.1 && pace <= 1e6)
                   ? std::string()
                   : "0 (as fast as the CPU allows) or 0.1 .. 1e6";
      });
  if (!with_faults) return;
  cmd->add_option(
      "--inject", args->faults,
      "A fault the embedded rig injects, KIND:at=CYCLE[,key=value] "
      "(repeatable; --rig sim only): late:at=C,delay=S, stale:at=C,cycles=N, "
      "lost:at=C, corrupt:at=C, silent:at=C, stuck:at=C,channel=CH, "
      "nan:at=C,channel=CH (CH one of x y z toe camber caster Fx Fy Fz)");
}

Status CheckSilRigOptions(const SilRigArgs& args, const std::string& rig) {
  if (rig == "sim") return Status::Ok();
  std::string given;
  for (const auto& [option, used] :
       {std::pair<const char*, bool>{"--seed", args.seed.has_value()},
        {"--plant-effect", !args.plant_effects.empty()},
        {"--plant-set", !args.plant_sets.empty()},
        {"--inject", !args.faults.empty()},
        {"--pace", args.pace.has_value()}}) {
    if (used) given += (given.empty() ? "" : ", ") + std::string(option);
  }
  if (given.empty()) return Status::Ok();
  return Status::Error(given +
                       ": only the embedded rig (--rig sim) has a sensor "
                       "noise, a plant and faults of kcrig's own; give a "
                       "kcrig emulate rig its effects with emulate --effect");
}

Status LoadSilPlant(const SilRigArgs& args, const KcrigConfig& config,
                    PlantConfig* plant, std::vector<InjectedFault>* faults) {
  KCRIG_RETURN_IF_ERROR(LoadPlantConfig(config.directory, config.model, plant));
  if (args.seed) plant->seed = *args.seed;
  for (const std::string& effect : args.plant_effects) {
    const Status status = ParseEffect(effect, &plant->effects);
    if (!status.ok()) {
      return Status::Error("--plant-effect " + status.message());
    }
  }
  for (const std::string& set : args.plant_sets) {
    KCRIG_RETURN_IF_ERROR(
        ApplyParameterAssignment("--plant-set", set, &plant->model));
  }
  KCRIG_RETURN_IF_ERROR(ValidateModel(plant->model, "--plant-set"));
  faults->assign(args.faults.size(), InjectedFault());
  for (size_t i = 0; i < args.faults.size(); ++i) {
    const Status status = ParseInjectedFault(args.faults[i], &(*faults)[i]);
    if (!status.ok()) return Status::Error("--inject " + status.message());
  }
  return Status::Ok();
}

double SilRigPace(const SilRigArgs& args, bool console) {
  if (args.pace) return *args.pace;
  return console ? 1.0 : 0.0;
}

std::string DescribePace(double pace) {
  if (pace <= 0) return "";
  char text[64];
  std::snprintf(text, sizeof(text), ", paced at %g x real time", pace);
  return text;
}

std::string DescribeSilRig(const SilRigArgs& args, const PlantConfig& plant) {
  std::string text = "embedded SIL rig (plant.yaml, virtual clock)";
  const std::vector<std::string> effects = DescribeEffects(plant.effects);
  for (size_t i = 0; i < effects.size(); ++i) {
    text += (i == 0 ? ", plant effects: " : " ") + effects[i];
  }
  for (size_t i = 0; i < args.plant_sets.size(); ++i) {
    text += (i == 0 ? ", plant parameters: " : " ") + args.plant_sets[i];
  }
  for (size_t i = 0; i < args.faults.size(); ++i) {
    text += (i == 0 ? ", injected faults: " : " ") + args.faults[i];
  }
  return text;
}

}  // namespace kcrig
