#include "emulator/plant_config.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <vector>

#include "base/yaml_reader.h"
#include "rt_core/model/model_config.h"

namespace kcrig {
namespace {

// The optional `effects` list, each entry in the --effect syntax.
Status ReadEffects(const YamlReader& reader, const YAML::Node& root,
                   PlantEffects* effects) {
  if (!root["effects"]) return Status::Ok();
  YAML::Node list;
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "effects", &list));
  if (!list.IsSequence()) {
    return reader.Error(list, "effects",
                        "expected a list of effects NAME[:k=v,...]");
  }
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string key = "effects[" + std::to_string(i) + "]";
    if (!list[i].IsScalar()) {
      return reader.Error(list[i], key, "expected NAME[:k=v,...]");
    }
    const Status status = ParseEffect(list[i].as<std::string>(), effects);
    if (!status.ok()) return reader.Error(list[i], key, status.message());
  }
  return Status::Ok();
}

// The unit of parameter `name` ("N/m", "N s/m", "m", ...).
std::string UnitOf(SuspensionParameters<double>* model,
                   const std::string& name) {
  for (const NamedParameter<double>& p : ListParameters(model)) {
    if (p.name == name) return p.unit;
  }
  return "";
}

// A true stiffness, damping or coordinate within what a suspension can
// have, named with its line (a stiffness of 4.9e-324 N/m is a typo).
Status CheckTrueValue(const YamlReader& reader, const YAML::Node& node,
                      const std::string& name, const std::string& unit,
                      double value) {
  const std::string key = "true_parameters." + name;
  if (unit == "N/m" && !(value >= 1e3 && value <= 1e12)) {
    return reader.Error(node, key, "must be within [1000, 1e+12] N/m");
  }
  if (unit == "N s/m" && !(value >= 0 && value <= 1e12)) {
    return reader.Error(node, key, "must be within [0, 1e+12] N s/m");
  }
  if (unit == "m" && !(std::abs(value) <= 10)) {
    return reader.Error(node, key, "must be within [-10, 10] m");
  }
  return Status::Ok();
}

}  // namespace

Status LoadPlantConfig(const std::string& directory,
                       const SuspensionParameters<double>& model,
                       PlantConfig* plant) {
  const std::string file =
      (std::filesystem::path(directory) / "plant.yaml").string();
  YamlReader reader(file);
  YAML::Node root;
  KCRIG_RETURN_IF_ERROR(reader.Load(&root));
  plant->model = model;
  YAML::Node truth, sensors;
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "true_parameters", &truth));
  if (!truth.IsMap()) {
    return reader.Error(truth, "true_parameters",
                        "expected a mapping NAME: VALUE");
  }
  for (const auto& entry : truth) {
    // A complex key (YAML's "? key") has no name to look up.
    if (!entry.first.IsScalar()) {
      return reader.Error(entry.first, "true_parameters",
                          "expected a mapping NAME: VALUE");
    }
    const std::string name = entry.first.Scalar();
    double* parameter = FindParameter(&plant->model, name);
    if (parameter == nullptr) {
      return reader.Error(entry.first, "true_parameters." + name,
                          "unknown parameter (e.g. c_O1, d_P, k_spring)");
    }
    KCRIG_RETURN_IF_ERROR(
        reader.Number(truth, "true_parameters", name, parameter));
    KCRIG_RETURN_IF_ERROR(CheckTrueValue(
        reader, entry.second, name, UnitOf(&plant->model, name), *parameter));
  }
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "sensors", &sensors));
  KCRIG_RETURN_IF_ERROR(
      reader.Boolean(sensors, "sensors", "noise", &plant->noise));
  double seed = 0;
  KCRIG_RETURN_IF_ERROR(reader.Number(sensors, "sensors", "seed", &seed));
  if (seed < 0 || seed != std::floor(seed) || seed > 9.0e15) {
    return reader.Error(sensors["seed"], "sensors.seed",
                        "must be a whole number >= 0");
  }
  plant->seed = static_cast<std::uint64_t>(seed);
  std::vector<double> offset;
  KCRIG_RETURN_IF_ERROR(reader.List(sensors, "sensors", "offset", 6, &offset));
  for (int k = 0; k < 6; ++k) plant->sensor_offset(k) = offset[k];
  KCRIG_RETURN_IF_ERROR(reader.InRange(sensors, "sensors",
                                       "position_resolution", 0, 1e-3,
                                       &plant->position_resolution));
  KCRIG_RETURN_IF_ERROR(reader.InRange(sensors, "sensors", "angle_resolution",
                                       0, 1e-2, &plant->angle_resolution));
  YAML::Node actuator, rig, load_cell;
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "actuator", &actuator));
  KCRIG_RETURN_IF_ERROR(reader.InRange(actuator, "actuator", "tau", 1e-5, 1,
                                       &plant->actuator_tau));
  KCRIG_RETURN_IF_ERROR(reader.InRange(actuator, "actuator", "dead_time", 0,
                                       0.1, &plant->actuator_dead_time));
  KCRIG_RETURN_IF_ERROR(reader.InRange(actuator, "actuator", "force_max", 1,
                                       1e5, &plant->actuator_force_max));
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "rig", &rig));
  KCRIG_RETURN_IF_ERROR(
      reader.InRange(rig, "rig", "step", 1e-6, 1e-3, &plant->step));
  KCRIG_RETURN_IF_ERROR(
      reader.Integer(rig, "rig", "priority", 0, 99, &plant->priority));
  if (rig["cpu"]) {  // optional: older plant.yaml files have no rig.cpu
    KCRIG_RETURN_IF_ERROR(
        reader.Integer(rig, "rig", "cpu", -1, 1023, &plant->cpu));
  }
  KCRIG_RETURN_IF_ERROR(
      reader.InRange(rig, "rig", "travel_max", 1e-4, 0.5, &plant->travel_max));
  KCRIG_RETURN_IF_ERROR(reader.InRange(rig, "rig", "command_timeout", 1e-3, 1,
                                       &plant->command_timeout));
  if (rig["claim_timeout"]) {  // optional: older plant.yaml files
    KCRIG_RETURN_IF_ERROR(reader.InRange(rig, "rig", "claim_timeout",
                                         plant->command_timeout, 60,
                                         &plant->claim_timeout));
  } else {
    plant->claim_timeout =
        std::max(plant->claim_timeout, plant->command_timeout);
  }
  KCRIG_RETURN_IF_ERROR(reader.InRange(rig, "rig", "ramp_down_time", 1e-3, 10,
                                       &plant->ramp_down_time));
  if (rig["rest_between_runs"]) {  // optional: older plant.yaml files
    KCRIG_RETURN_IF_ERROR(reader.InRange(rig, "rig", "rest_between_runs", 0,
                                         3600, &plant->rest_between_runs));
  }
  if (rig["keeps_state"]) {  // optional: older plant.yaml files
    KCRIG_RETURN_IF_ERROR(
        reader.Boolean(rig, "rig", "keeps_state", &plant->keeps_state));
  }
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "load_cell", &load_cell));
  KCRIG_RETURN_IF_ERROR(reader.InRange(load_cell, "load_cell", "sigma", 0, 1e3,
                                       &plant->load_cell_sigma));
  KCRIG_RETURN_IF_ERROR(reader.InRange(load_cell, "load_cell", "resolution", 0,
                                       100, &plant->load_cell_resolution));
  KCRIG_RETURN_IF_ERROR(ReadEffects(reader, root, &plant->effects));
  KCRIG_RETURN_IF_ERROR(reader.CheckNoUnknownKeys(root));
  return ValidateModel(plant->model, file);
}

}  // namespace kcrig
