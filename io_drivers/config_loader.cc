#include "io_drivers/config_loader.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <sstream>
#include <vector>

#include "yaml-cpp/yaml.h"

namespace kcrig {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

#define KCRIG_RETURN_IF_ERROR(expr)    \
  do {                                 \
    const Status _status = (expr);     \
    if (!_status.ok()) return _status; \
  } while (0)

// Walks one YAML document and turns every problem into "file:line: key: what".
class YamlReader {
 public:
  explicit YamlReader(std::string file) : file_(std::move(file)) {}

  Status Load(YAML::Node* root) {
    try {
      *root = YAML::LoadFile(file_);
    } catch (const YAML::BadFile&) {
      return Status::Error(file_ + ": cannot open");
    } catch (const YAML::Exception& e) {
      return Status::Error(file_ + ":" + std::to_string(e.mark.line + 1) +
                           ": malformed YAML: " + e.msg);
    }
    if (!root->IsMap()) return Status::Error(file_ + ": expected a mapping");
    return Status::Ok();
  }

  Status Child(const YAML::Node& parent, const std::string& parent_key,
               const std::string& key, YAML::Node* out) const {
    const std::string full = parent_key.empty() ? key : parent_key + "." + key;
    // Indexing a scalar or a list would throw: say what was expected.
    if (!parent.IsMap()) {
      return Status::Error(Where(parent) +
                           (parent_key.empty() ? "document" : parent_key) +
                           ": expected a mapping with '" + key + "'");
    }
    const YAML::Node child = parent[key];
    if (!child) {
      return Status::Error(Where(parent) + full + ": missing key");
    }
    *out = child;
    return Status::Ok();
  }

  Status Number(const YAML::Node& parent, const std::string& parent_key,
                const std::string& key, double* out) const {
    YAML::Node node;
    Status status = Child(parent, parent_key, key, &node);
    if (!status.ok()) return status;
    return ToNumber(node, Join(parent_key, key), out);
  }

  // Number with a range: > 0 (`strictly`) or >= 0.
  Status Positive(const YAML::Node& parent, const std::string& parent_key,
                  const std::string& key, double* out,
                  bool strictly = true) const {
    KCRIG_RETURN_IF_ERROR(Number(parent, parent_key, key, out));
    if (strictly ? !(*out > 0) : !(*out >= 0)) {
      return Error(parent[key], Join(parent_key, key),
                   strictly ? "must be > 0" : "must be >= 0");
    }
    return Status::Ok();
  }

  // A whole number within [lower, upper].
  Status Integer(const YAML::Node& parent, const std::string& parent_key,
                 const std::string& key, int lower, int upper, int* out) const {
    double value = 0;
    KCRIG_RETURN_IF_ERROR(Number(parent, parent_key, key, &value));
    if (value != std::floor(value) || value < lower || value > upper) {
      return Error(parent[key], Join(parent_key, key),
                   "must be a whole number in [" + std::to_string(lower) +
                       ", " + std::to_string(upper) + "]");
    }
    *out = static_cast<int>(value);
    return Status::Ok();
  }

  // A plain string (not a list, not a mapping, not empty).
  Status String(const YAML::Node& parent, const std::string& parent_key,
                const std::string& key, std::string* out) const {
    YAML::Node node;
    KCRIG_RETURN_IF_ERROR(Child(parent, parent_key, key, &node));
    if (!node.IsScalar() || node.Scalar().empty()) {
      return Error(node, Join(parent_key, key), "expected a text value");
    }
    *out = node.Scalar();
    return Status::Ok();
  }

  Status Boolean(const YAML::Node& parent, const std::string& parent_key,
                 const std::string& key, bool* out) const {
    YAML::Node node;
    KCRIG_RETURN_IF_ERROR(Child(parent, parent_key, key, &node));
    try {
      *out = node.as<bool>();
    } catch (const YAML::Exception&) {
      return Error(node, Join(parent_key, key), "expected true or false");
    }
    return Status::Ok();
  }

  Status Vector3(const YAML::Node& parent, const std::string& parent_key,
                 const std::string& key, Vec3<double>* out) const {
    std::vector<double> values;
    Status status = List(parent, parent_key, key, 3, &values);
    if (!status.ok()) return status;
    *out << values[0], values[1], values[2];
    return Status::Ok();
  }

  Status List(const YAML::Node& parent, const std::string& parent_key,
              const std::string& key, size_t size,
              std::vector<double>* out) const {
    YAML::Node node;
    const std::string full = Join(parent_key, key);
    Status status = Child(parent, parent_key, key, &node);
    if (!status.ok()) return status;
    if (!node.IsSequence() || node.size() != size) {
      return Status::Error(Where(node) + full + ": expected a list of " +
                           std::to_string(size) + " numbers");
    }
    out->resize(size);
    for (size_t i = 0; i < size; ++i) {
      status =
          ToNumber(node[i], full + "[" + std::to_string(i) + "]", &(*out)[i]);
      if (!status.ok()) return status;
    }
    return Status::Ok();
  }

  Status Error(const YAML::Node& node, const std::string& key,
               const std::string& what) const {
    return Status::Error(Where(node) + key + ": " + what);
  }

 private:
  static std::string Join(const std::string& a, const std::string& b) {
    return a.empty() ? b : a + "." + b;
  }

  std::string Where(const YAML::Node& node) const {
    const YAML::Mark mark = node.Mark();
    if (mark.line < 0) return file_ + ": ";
    return file_ + ":" + std::to_string(mark.line + 1) + ": ";
  }

  Status ToNumber(const YAML::Node& node, const std::string& key,
                  double* out) const {
    if (!node.IsScalar()) {
      return Status::Error(Where(node) + key + ": expected a number");
    }
    try {
      *out = node.as<double>();
    } catch (const YAML::Exception&) {
      return Status::Error(Where(node) + key + ": expected a number, got '" +
                           node.Scalar() + "'");
    }
    if (!std::isfinite(*out)) {
      return Status::Error(Where(node) + key + ": must be finite");
    }
    return Status::Ok();
  }

  std::string file_;
};

Status LoadElement(const YamlReader& reader, const YAML::Node& parent,
                   const std::string& parent_key, const std::string& name,
                   AxialElement<double>* element) {
  YAML::Node node;
  KCRIG_RETURN_IF_ERROR(reader.Child(parent, parent_key, name, &node));
  const std::string key = parent_key.empty() ? name : parent_key + "." + name;
  KCRIG_RETURN_IF_ERROR(
      reader.Vector3(node, key, "chassis", &element->chassis_point));
  KCRIG_RETURN_IF_ERROR(
      reader.Vector3(node, key, "carrier", &element->carrier_point));
  KCRIG_RETURN_IF_ERROR(
      reader.Number(node, key, "stiffness", &element->stiffness));
  return reader.Number(node, key, "damping", &element->damping);
}

Status LoadModel(const std::string& file, SuspensionParameters<double>* model) {
  YamlReader reader(file);
  YAML::Node root;
  KCRIG_RETURN_IF_ERROR(reader.Load(&root));
  KCRIG_RETURN_IF_ERROR(reader.Number(root, "", "mass", &model->mass));
  KCRIG_RETURN_IF_ERROR(reader.Vector3(root, "", "inertia", &model->inertia));
  YAML::Node bushings;
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "bushings", &bushings));
  for (int i = 0; i < kNumBushings; ++i) {
    KCRIG_RETURN_IF_ERROR(LoadElement(reader, bushings, "bushings",
                                      std::string(kBushingChassisNames[i]),
                                      &model->bushings[i]));
  }
  KCRIG_RETURN_IF_ERROR(
      LoadElement(reader, root, "", "spring", &model->spring));
  return ValidateModel(*model, file);
}

Status LoadExperiment(const std::string& file, ExperimentConfig* experiment) {
  YamlReader reader(file);
  YAML::Node root;
  KCRIG_RETURN_IF_ERROR(reader.Load(&root));
  YAML::Node excitation, integrator, measurement, bounds;
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "excitation", &excitation));
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "integrator", &integrator));
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "measurement", &measurement));
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "design_bounds", &bounds));

  double phi_deg = 0, sigma_angle_deg = 0;
  KCRIG_RETURN_IF_ERROR(
      reader.Number(excitation, "excitation", "phi_deg", &phi_deg));
  KCRIG_RETURN_IF_ERROR(
      reader.Number(excitation, "excitation", "z_a", &experiment->z_a));
  KCRIG_RETURN_IF_ERROR(
      reader.Number(excitation, "excitation", "fmax", &experiment->fmax));
  KCRIG_RETURN_IF_ERROR(reader.Number(excitation, "excitation", "duration",
                                      &experiment->duration));
  KCRIG_RETURN_IF_ERROR(
      reader.Number(excitation, "excitation", "rate", &experiment->rate));
  KCRIG_RETURN_IF_ERROR(
      reader.Number(integrator, "integrator", "step", &experiment->step));
  KCRIG_RETURN_IF_ERROR(reader.Number(measurement, "measurement",
                                      "sigma_position",
                                      &experiment->sigma_position));
  KCRIG_RETURN_IF_ERROR(reader.Number(measurement, "measurement",
                                      "sigma_angle_deg", &sigma_angle_deg));
  experiment->phi = phi_deg * kDegree;
  experiment->sigma_angle = sigma_angle_deg * kDegree;

  std::vector<double> phi_bounds, z_bounds;
  KCRIG_RETURN_IF_ERROR(
      reader.List(bounds, "design_bounds", "phi_deg", 2, &phi_bounds));
  KCRIG_RETURN_IF_ERROR(
      reader.List(bounds, "design_bounds", "z_a", 2, &z_bounds));
  experiment->phi_bounds = {phi_bounds[0] * kDegree, phi_bounds[1] * kDegree};
  experiment->z_a_bounds = {z_bounds[0], z_bounds[1]};

  const struct {
    const YAML::Node& node;
    const char* section;
    const char* key;
    double value;
  } must_be_positive[] = {
      {excitation, "excitation", "fmax", experiment->fmax},
      {excitation, "excitation", "duration", experiment->duration},
      {excitation, "excitation", "rate", experiment->rate},
      {integrator, "integrator", "step", experiment->step},
      {measurement, "measurement", "sigma_position",
       experiment->sigma_position},
      {measurement, "measurement", "sigma_angle_deg", experiment->sigma_angle},
  };
  for (const auto& check : must_be_positive) {
    if (!(check.value > 0)) {
      return reader.Error(check.node[check.key],
                          std::string(check.section) + "." + check.key,
                          "must be > 0");
    }
  }
  if (!(phi_bounds[0] < phi_bounds[1])) {
    return reader.Error(bounds["phi_deg"], "design_bounds.phi_deg",
                        "lower bound must be below the upper bound");
  }
  if (!(z_bounds[0] < z_bounds[1])) {
    return reader.Error(bounds["z_a"], "design_bounds.z_a",
                        "lower bound must be below the upper bound");
  }
  return Status::Ok();
}

}  // namespace

Status ValidateModel(const SuspensionParameters<double>& model,
                     const std::string& source) {
  auto error = [&](const std::string& key, const std::string& what) {
    return Status::Error(source + ": " + key + ": " + what);
  };
  SuspensionParameters<double> copy = model;
  for (const NamedParameter<double>& p : ListParameters(&copy)) {
    if (!std::isfinite(*p.value)) return error(p.name, "must be finite");
  }
  if (!(model.mass > 0)) return error("mass", "must be > 0");
  for (int k = 0; k < 3; ++k) {
    if (!(model.inertia(k) > 0)) {
      return error("inertia[" + std::to_string(k) + "]", "must be > 0");
    }
  }
  constexpr double kMinLinkLength = 1e-3;  // [m]
  for (int i = 0; i < kNumBushings; ++i) {
    const std::string name(kBushingChassisNames[i]);
    const AxialElement<double>& e = model.bushings[i];
    if (!(e.stiffness > 0))
      return error("bushings." + name + ".stiffness", "must be > 0");
    if (!(e.damping >= 0))
      return error("bushings." + name + ".damping", "must be >= 0");
    if ((e.chassis_point - e.carrier_point).norm() < kMinLinkLength) {
      return error(
          "bushings." + name,
          "degenerate link: chassis and carrier points closer than 1 mm");
    }
  }
  if (!(model.spring.stiffness >= 0))
    return error("spring.stiffness", "must be >= 0");
  if (!(model.spring.damping >= 0))
    return error("spring.damping", "must be >= 0");
  if ((model.spring.chassis_point - model.spring.carrier_point).norm() <
      kMinLinkLength) {
    return error("spring",
                 "degenerate: chassis and carrier points closer than 1 mm");
  }
  return Status::Ok();
}

Status LoadConfig(const std::string& given_directory, KcrigConfig* config) {
  namespace fs = std::filesystem;
  const std::string directory =
      given_directory.empty() ? DefaultConfigDirectory() : given_directory;
  if (!fs::is_directory(directory)) {
    return Status::Error(directory + ": config directory not found");
  }
  config->directory = directory;
  KCRIG_RETURN_IF_ERROR(
      LoadModel((fs::path(directory) / "model.yaml").string(), &config->model));
  return LoadExperiment((fs::path(directory) / "experiment.yaml").string(),
                        &config->experiment);
}

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
  const std::vector<NamedParameter<double>> list =
      ListParameters(&plant->model);
  for (const auto& entry : truth) {
    const std::string name = entry.first.as<std::string>();
    const auto match = std::find_if(
        list.begin(), list.end(),
        [&name](const NamedParameter<double>& p) { return p.name == name; });
    if (match == list.end()) {
      return reader.Error(entry.first, "true_parameters." + name,
                          "unknown parameter (e.g. c_O1, d_P, k_spring)");
    }
    KCRIG_RETURN_IF_ERROR(
        reader.Number(truth, "true_parameters", name, match->value));
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
  KCRIG_RETURN_IF_ERROR(reader.Positive(sensors, "sensors",
                                        "position_resolution",
                                        &plant->position_resolution, false));
  KCRIG_RETURN_IF_ERROR(reader.Positive(sensors, "sensors", "angle_resolution",
                                        &plant->angle_resolution, false));
  YAML::Node actuator, rig, load_cell;
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "actuator", &actuator));
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(actuator, "actuator", "tau", &plant->actuator_tau));
  KCRIG_RETURN_IF_ERROR(reader.Positive(actuator, "actuator", "dead_time",
                                        &plant->actuator_dead_time, false));
  KCRIG_RETURN_IF_ERROR(reader.Positive(actuator, "actuator", "force_max",
                                        &plant->actuator_force_max));
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "rig", &rig));
  KCRIG_RETURN_IF_ERROR(reader.Positive(rig, "rig", "step", &plant->step));
  KCRIG_RETURN_IF_ERROR(
      reader.Integer(rig, "rig", "priority", 0, 99, &plant->priority));
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(rig, "rig", "travel_max", &plant->travel_max));
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(rig, "rig", "command_timeout", &plant->command_timeout));
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(rig, "rig", "ramp_down_time", &plant->ramp_down_time));
  if (plant->step > 1e-3) {
    return reader.Error(rig["step"], "rig.step",
                        "must be <= 0.001 s (the plant runs finer than the "
                        "controller)");
  }
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "load_cell", &load_cell));
  KCRIG_RETURN_IF_ERROR(reader.Positive(load_cell, "load_cell", "sigma",
                                        &plant->load_cell_sigma, false));
  KCRIG_RETURN_IF_ERROR(reader.Positive(load_cell, "load_cell", "resolution",
                                        &plant->load_cell_resolution, false));
  return ValidateModel(plant->model, file);
}

Status LoadRigConfig(const std::string& directory, RigConfig* rig) {
  const std::string file =
      (std::filesystem::path(directory) / "rig.yaml").string();
  YamlReader reader(file);
  YAML::Node root, loop, realtime, profile, safety, budget, modbus, rtu, can;
  KCRIG_RETURN_IF_ERROR(reader.Load(&root));
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "loop", &loop));
  KCRIG_RETURN_IF_ERROR(reader.Positive(loop, "loop", "period", &rig->period));
  if (rig->period < 1e-4 || rig->period > 0.1) {
    return reader.Error(loop["period"], "loop.period",
                        "must be within [0.0001, 0.1] s");
  }
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "realtime", &realtime));
  KCRIG_RETURN_IF_ERROR(reader.Integer(realtime, "realtime", "priority", 0, 99,
                                       &rig->realtime.priority));
  KCRIG_RETURN_IF_ERROR(reader.Integer(realtime, "realtime", "cpu", -1, 1023,
                                       &rig->realtime.cpu));
  KCRIG_RETURN_IF_ERROR(reader.Boolean(realtime, "realtime", "lock_memory",
                                       &rig->realtime.lock_memory));
  KCRIG_RETURN_IF_ERROR(reader.Boolean(realtime, "realtime", "no_cpu_idle",
                                       &rig->realtime.no_cpu_idle));
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "run_profile", &profile));
  RunProfileTimes& p = rig->profile;
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(profile, "run_profile", "tare", &p.tare));
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(profile, "run_profile", "lead_in", &p.lead_in));
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(profile, "run_profile", "settle", &p.settle, false));
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(profile, "run_profile", "ramp_down", &p.ramp_down));

  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "safety", &safety));
  SafetyLimits& l = rig->safety;
  double angle_max_deg = 0, error_angle_max_deg = 0;
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(safety, "safety", "force_max", &l.force_max));
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(safety, "safety", "force_rate_max", &l.force_rate_max));
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(safety, "safety", "travel_max", &l.travel_max));
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(safety, "safety", "angle_max_deg", &angle_max_deg));
  KCRIG_RETURN_IF_ERROR(reader.Positive(safety, "safety", "error_position_max",
                                        &l.error_position_max));
  KCRIG_RETURN_IF_ERROR(reader.Positive(safety, "safety", "error_angle_max_deg",
                                        &error_angle_max_deg));
  KCRIG_RETURN_IF_ERROR(reader.Integer(safety, "safety", "watchdog_cycles", 1,
                                       100000, &l.watchdog_cycles));
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(safety, "safety", "ramp_down_time", &l.ramp_down_time));
  l.angle_max = angle_max_deg * kDegree;
  l.error_angle_max = error_angle_max_deg * kDegree;
  if (l.force_max / l.ramp_down_time > l.force_rate_max) {
    return reader.Error(safety["ramp_down_time"], "safety.ramp_down_time",
                        "a trip at force_max would ramp down faster than "
                        "force_rate_max allows");
  }

  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "timing_budget", &budget));
  TimingBudget& b = rig->budget;
  KCRIG_RETURN_IF_ERROR(reader.Positive(budget, "timing_budget",
                                        "compute_p999_fraction",
                                        &b.compute_p999_fraction));
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(budget, "timing_budget", "wakeup_p99", &b.wakeup_p99));
  KCRIG_RETURN_IF_ERROR(reader.Positive(
      budget, "timing_budget", "cycle_p999_fraction", &b.cycle_p999_fraction));

  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "modbus", &modbus));
  ModbusSettings& m = rig->modbus;
  std::string map;
  KCRIG_RETURN_IF_ERROR(reader.String(modbus, "modbus", "map", &map));
  m.map_file = (std::filesystem::path(directory) / map).string();
  KCRIG_RETURN_IF_ERROR(reader.Positive(modbus, "modbus", "response_timeout",
                                        &m.response_timeout));
  if (m.response_timeout < 1e-5) {
    return reader.Error(modbus["response_timeout"], "modbus.response_timeout",
                        "must be >= 0.00001 s");
  }
  if (m.response_timeout > 0.5 * rig->period) {
    return reader.Error(modbus["response_timeout"], "modbus.response_timeout",
                        "must be <= half of loop.period (a read and a write "
                        "share one cycle)");
  }
  KCRIG_RETURN_IF_ERROR(reader.Positive(modbus, "modbus", "reconnect_interval",
                                        &m.reconnect_interval));
  if (m.reconnect_interval < 0.01) {
    return reader.Error(modbus["reconnect_interval"],
                        "modbus.reconnect_interval", "must be >= 0.01 s");
  }
  KCRIG_RETURN_IF_ERROR(reader.Child(modbus, "modbus", "rtu", &rtu));
  KCRIG_RETURN_IF_ERROR(
      reader.Integer(rtu, "modbus.rtu", "baud", 300, 4000000, &m.baud));
  KCRIG_RETURN_IF_ERROR(
      reader.Integer(rtu, "modbus.rtu", "data_bits", 5, 8, &m.data_bits));
  KCRIG_RETURN_IF_ERROR(
      reader.Integer(rtu, "modbus.rtu", "stop_bits", 1, 2, &m.stop_bits));
  std::string parity_text;
  KCRIG_RETURN_IF_ERROR(
      reader.String(rtu, "modbus.rtu", "parity", &parity_text));
  if (parity_text != "N" && parity_text != "E" && parity_text != "O") {
    return reader.Error(rtu["parity"], "modbus.rtu.parity",
                        "must be N, E or O");
  }
  m.parity = parity_text[0];

  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", "can", &can));
  CanSettings& c = rig->can;
  std::string dbc;
  KCRIG_RETURN_IF_ERROR(reader.String(can, "can", "dbc", &dbc));
  c.dbc_file = (std::filesystem::path(directory) / dbc).string();
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(can, "can", "tx_timeout", &c.tx_timeout));
  if (c.tx_timeout < rig->period || c.tx_timeout > 1) {
    return reader.Error(can["tx_timeout"], "can.tx_timeout",
                        "must be between loop.period and 1 s");
  }
  KCRIG_RETURN_IF_ERROR(
      reader.Positive(can, "can", "connect_timeout", &c.connect_timeout));
  if (c.connect_timeout > 60) {
    return reader.Error(can["connect_timeout"], "can.connect_timeout",
                        "must be <= 60 s");
  }
  return Status::Ok();
}

int ModbusMap::holding_count() const {
  int end = std::max(control_word, sequence) + 1;
  for (int a : setpoint) end = std::max(end, a + 2);
  end = std::max(end, z_a + 2);
  return end;
}

int ModbusMap::input_count() const {
  int end = std::max({status, fault_code, sequence_echo, protocol}) + 1;
  end = std::max(end, sample + 2);
  for (int a : force) end = std::max(end, a + 2);
  for (int a : y) end = std::max(end, a + 2);
  return end;
}

Status LoadModbusMap(const std::string& file, ModbusMap* map) {
  YamlReader reader(file);
  YAML::Node root;
  KCRIG_RETURN_IF_ERROR(reader.Load(&root));
  KCRIG_RETURN_IF_ERROR(
      reader.Integer(root, "", "unit_id", 0, 247, &map->unit_id));
  std::string order_text;
  KCRIG_RETURN_IF_ERROR(reader.String(root, "", "word_order", &order_text));
  if (order_text != "high_word_first" && order_text != "low_word_first") {
    return reader.Error(root["word_order"], "word_order",
                        "must be high_word_first or low_word_first");
  }
  map->high_word_first = order_text == "high_word_first";
  // (key, address, registers) per table; overlaps are errors.
  struct Field {
    const char* key;
    int* address;
    int width;
  };
  const Field holding_fields[] = {{"control_word", &map->control_word, 1},
                                  {"sequence", &map->sequence, 1},
                                  {"fx_setpoint", &map->setpoint[0], 2},
                                  {"fy_setpoint", &map->setpoint[1], 2},
                                  {"fz_setpoint", &map->setpoint[2], 2},
                                  {"za_setpoint", &map->z_a, 2}};
  const Field input_fields[] = {{"status", &map->status, 1},
                                {"fault_code", &map->fault_code, 1},
                                {"sample", &map->sample, 2},
                                {"sequence_echo", &map->sequence_echo, 1},
                                {"protocol", &map->protocol, 1},
                                {"fx", &map->force[0], 2},
                                {"fy", &map->force[1], 2},
                                {"fz", &map->force[2], 2},
                                {"x", &map->y[0], 2},
                                {"y", &map->y[1], 2},
                                {"z", &map->y[2], 2},
                                {"toe", &map->y[3], 2},
                                {"camber", &map->y[4], 2},
                                {"caster", &map->y[5], 2}};
  auto load_table = [&](const char* table, const Field* fields,
                        size_t count) -> Status {
    YAML::Node node;
    KCRIG_RETURN_IF_ERROR(reader.Child(root, "", table, &node));
    std::vector<int> owner(256, -1);
    for (size_t i = 0; i < count; ++i) {
      KCRIG_RETURN_IF_ERROR(reader.Integer(node, table, fields[i].key, 0, 254,
                                           fields[i].address));
      for (int r = 0; r < fields[i].width; ++r) {
        int& slot = owner[*fields[i].address + r];
        if (slot >= 0) {
          return reader.Error(node[fields[i].key],
                              std::string(table) + "." + fields[i].key,
                              "overlaps " + std::string(fields[slot].key));
        }
        slot = static_cast<int>(i);
      }
    }
    return Status::Ok();
  };
  KCRIG_RETURN_IF_ERROR(load_table("holding_registers", holding_fields,
                                   std::size(holding_fields)));
  KCRIG_RETURN_IF_ERROR(
      load_table("input_registers", input_fields, std::size(input_fields)));
  if (map->input_count() > 125 || map->holding_count() > 123) {
    return Status::Error(file +
                         ": the map must fit one request per table (<= 125 "
                         "input, <= 123 holding registers)");
  }
  return Status::Ok();
}

std::string DefaultConfigDirectory() {
  if (std::filesystem::is_directory(KCRIG_INSTALLED_CONFIG_DIR)) {
    return KCRIG_INSTALLED_CONFIG_DIR;
  }
  return KCRIG_SOURCE_CONFIG_DIR;
}

}  // namespace kcrig

namespace kcrig {

std::string GeometryFingerprint(const SuspensionParameters<double>& model) {
  SuspensionParameters<double> copy = model;
  // FNV-1a over the names and the values printed to 9 significant digits
  // (stable across platforms, blind to YAML formatting).
  std::uint64_t hash = 1469598103934665603ULL;
  auto mix = [&hash](const std::string& text) {
    for (unsigned char c : text) {
      hash ^= c;
      hash *= 1099511628211ULL;
    }
  };
  for (const NamedParameter<double>& p : ListParameters(&copy)) {
    if (p.name.rfind("c_", 0) == 0) continue;
    char value[40];
    std::snprintf(value, sizeof(value), "=%.9g;", *p.value);
    mix(p.name + value);
  }
  char hex[17];
  std::snprintf(hex, sizeof(hex), "%016llx",
                static_cast<unsigned long long>(hash));
  return hex;
}

}  // namespace kcrig
