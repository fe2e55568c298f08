#include "hil/rig_config.h"

#include <filesystem>

#include "base/yaml_reader.h"

namespace kcrig {

Status LoadRigConfig(const std::string& directory, RigConfig* rig) {
  const std::string file =
      (std::filesystem::path(directory) / "rig.yaml").string();
  YamlReader reader(file);
  YAML::Node root, budget;
  KCRIG_RETURN_IF_ERROR(reader.Load(&root));
  KCRIG_RETURN_IF_ERROR(LoadLoopConfig(reader, root, rig));
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "timing_budget", &budget));
  TimingBudget& b = rig->budget;
  // A budget beyond these always passes: no budget at all.
  KCRIG_RETURN_IF_ERROR(reader.InRange(budget, "timing_budget",
                                       "compute_p999_fraction", 1e-3, 1,
                                       &b.compute_p999_fraction));
  KCRIG_RETURN_IF_ERROR(reader.InRange(budget, "timing_budget", "wakeup_p99",
                                       1e-6, 1, &b.wakeup_p99));
  KCRIG_RETURN_IF_ERROR(reader.InRange(budget, "timing_budget",
                                       "cycle_p999_fraction", 1e-3, 1,
                                       &b.cycle_p999_fraction));
  KCRIG_RETURN_IF_ERROR(reader.InRange(budget, "timing_budget",
                                       "overrun_max_fraction", 0.0, 1.0,
                                       &b.overrun_max_fraction));

  KCRIG_RETURN_IF_ERROR(
      LoadModbusSettings(reader, root, directory, rig->period, &rig->modbus));
  KCRIG_RETURN_IF_ERROR(
      LoadCanSettings(reader, root, directory, rig->period, &rig->can));
  return reader.CheckNoUnknownKeys(root);
}

}  // namespace kcrig
