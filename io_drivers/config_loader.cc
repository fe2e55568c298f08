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

#define KCRIG_RETURN_IF_ERROR(expr)    \
  do {                                 \
    const Status _status = (expr);     \
    if (!_status.ok()) return _status; \
  } while (0)

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
  YAML::Node noise;
  KCRIG_RETURN_IF_ERROR(reader.Child(sensors, "sensors", "noise", &noise));
  try {
    plant->noise = noise.as<bool>();
  } catch (const YAML::Exception&) {
    return reader.Error(noise, "sensors.noise", "expected true or false");
  }
  double seed = 0;
  KCRIG_RETURN_IF_ERROR(reader.Number(sensors, "sensors", "seed", &seed));
  if (seed < 0 || seed != std::floor(seed) || seed > 9.0e15) {
    return reader.Error(sensors["seed"], "sensors.seed",
                        "must be a whole number >= 0");
  }
  plant->seed = static_cast<std::uint64_t>(seed);
  return ValidateModel(plant->model, file);
}

std::string DefaultConfigDirectory() {
  if (std::filesystem::is_directory(KCRIG_INSTALLED_CONFIG_DIR)) {
    return KCRIG_INSTALLED_CONFIG_DIR;
  }
  return KCRIG_SOURCE_CONFIG_DIR;
}

}  // namespace kcrig
