#include "rt_core/model/model_config.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <vector>

#include "base/fnv1a.h"
#include "base/yaml_reader.h"
#include "rt_core/model/channels.h"

namespace kcrig {
namespace {

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
  KCRIG_RETURN_IF_ERROR(reader.CheckNoUnknownKeys(root));
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

  // Ranges a physical test stays within; beyond them a value is a typo
  // that would make a simulation run for years or overflow.
  char range[64];
  const struct {
    const YAML::Node& node;
    const char* section;
    const char* key;
    double value;
    double max;
  } positive_up_to[] = {
      {excitation, "excitation", "fmax", experiment->fmax, 1e5},
      {excitation, "excitation", "duration", experiment->duration, 3600},
      {excitation, "excitation", "rate", experiment->rate, 1e5},
      {integrator, "integrator", "step", experiment->step, 0.1},
      {measurement, "measurement", "sigma_position", experiment->sigma_position,
       0.1},
      {measurement, "measurement", "sigma_angle_deg", sigma_angle_deg, 10},
  };
  for (const auto& check : positive_up_to) {
    if (!(check.value > 0 && check.value <= check.max)) {
      std::snprintf(range, sizeof(range), "must be within (0, %g]", check.max);
      return reader.Error(check.node[check.key],
                          std::string(check.section) + "." + check.key, range);
    }
  }
  if (!(std::abs(phi_deg) <= 360)) {
    return reader.Error(excitation["phi_deg"], "excitation.phi_deg",
                        "must be within [-360, 360]");
  }
  if (!(std::abs(experiment->z_a) <= 2)) {
    return reader.Error(excitation["z_a"], "excitation.z_a",
                        "must be within [-2, 2] m");
  }
  if (!(phi_bounds[0] < phi_bounds[1])) {
    return reader.Error(bounds["phi_deg"], "design_bounds.phi_deg",
                        "lower bound must be below the upper bound");
  }
  if (!(z_bounds[0] < z_bounds[1])) {
    return reader.Error(bounds["z_a"], "design_bounds.z_a",
                        "lower bound must be below the upper bound");
  }
  return reader.CheckNoUnknownKeys(root);
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
  // Upper ends far beyond any suspension, short of what overflows.
  if (!(model.mass > 0 && model.mass <= 1e4)) {
    return error("mass", "must be within (0, 1e4] kg");
  }
  for (int k = 0; k < 3; ++k) {
    if (!(model.inertia(k) > 0 && model.inertia(k) <= 1e4)) {
      return error("inertia[" + std::to_string(k) + "]",
                   "must be within (0, 1e4] kg m^2");
    }
  }
  for (const NamedParameter<double>& p : ListParameters(&copy)) {
    if (p.unit == "m" && !(std::abs(*p.value) <= 10)) {
      return error(p.name, "must be within [-10, 10] m");
    }
    if ((p.unit == "N/m" || p.unit == "N s/m") && !(*p.value <= 1e12)) {
      return error(p.name, "must be <= 1e12 " + p.unit);
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

std::string DefaultConfigDirectory() {
  namespace fs = std::filesystem;
  // Relative to the binary, not to a prefix fixed at build time: a package
  // unpacked anywhere reads its own config, and a build tree's binary never
  // reads a kcrig installed on the machine. A binary outside its build tree
  // (installed, or copied) never falls back to the build machine's source
  // folder: without a config beside it, the error names where it looked.
  std::error_code error;
  const fs::path binary = fs::read_symlink("/proc/self/exe", error);
  if (error) return KCRIG_SOURCE_CONFIG_DIR;
  const fs::path beside =
      (binary.parent_path() / KCRIG_CONFIG_DIR_FROM_BINARY).lexically_normal();
  const std::string tree = fs::path(KCRIG_BUILD_TREE).lexically_normal();
  const bool in_build_tree = binary.string().rfind(tree + "/", 0) == 0;
  if (in_build_tree && !fs::is_directory(beside, error)) {
    return KCRIG_SOURCE_CONFIG_DIR;
  }
  return beside.string();
}

std::string GeometryFingerprint(const SuspensionParameters<double>& model) {
  SuspensionParameters<double> copy = model;
  // The names and the values printed to 9 significant digits (stable
  // across platforms, blind to YAML formatting).
  Fnv1a hash;
  for (const NamedParameter<double>& p : ListParameters(&copy)) {
    if (p.name.rfind("c_", 0) == 0) continue;
    char value[40];
    std::snprintf(value, sizeof(value), "=%.9g;", *p.value);
    hash.Mix(p.name + value);
  }
  return hash.Hex();
}
}  // namespace kcrig
