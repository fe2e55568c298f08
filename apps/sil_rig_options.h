// The embedded SIL rig's options (`--rig sim`), shared by `kcrig run` and
// `kcrig campaign`: its noise seed, the plant's unmodelled effects and
// parameters, and (kcrig run) the faults it injects.
#ifndef KCRIG_APPS_SIL_RIG_OPTIONS_H_
#define KCRIG_APPS_SIL_RIG_OPTIONS_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "CLI/CLI.hpp"
#include "base/status.h"
#include "emulator/injected_fault.h"
#include "emulator/plant_config.h"
#include "rt_core/model/model_config.h"

namespace kcrig {

struct SilRigArgs {
  std::optional<std::uint64_t> seed;
  std::vector<std::string> plant_effects;
  std::vector<std::string> plant_sets;
  std::vector<std::string> faults;  // --inject
  // --pace: the virtual clock at most this many times real time.
  std::optional<double> pace;
};

// --seed, --plant-effect, --plant-set; --inject with `with_faults`.
void AddSilRigOptions(CLI::App* cmd, SilRigArgs* args, bool with_faults);

// Refuses the options for any rig but `sim`: only the embedded rig has a
// plant to change and faults to inject.
Status CheckSilRigOptions(const SilRigArgs& args, const std::string& rig);

// plant.yaml with the options' changes, and the faults parsed.
Status LoadSilPlant(const SilRigArgs& args, const KcrigConfig& config,
                    PlantConfig* plant, std::vector<InjectedFault>* faults);

// The virtual clock's pace (VirtualClock::set_pace): --pace, else real
// time when a console watches (a run of seconds would be over before a
// page opened), else as fast as the CPU allows.
double SilRigPace(const SilRigArgs& args, bool console);
// ", paced at 1 x real time" ("" for 0).
std::string DescribePace(double pace);

// "embedded SIL rig (plant.yaml, virtual clock), plant effects: ...".
std::string DescribeSilRig(const SilRigArgs& args, const PlantConfig& plant);

}  // namespace kcrig

#endif  // KCRIG_APPS_SIL_RIG_OPTIONS_H_
