#include "validation/blind_case.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "base/yaml_reader.h"
#include "rt_core/model/channels.h"

namespace kcrig {
namespace {

double LogUniform(double low, double high, double u) {
  return low * std::pow(high / low, u);
}

// The --effect text of a library effect of magnitude m (0..1).
std::string EffectText(const std::string& truth, double m, std::mt19937_64* rng,
                       std::uniform_real_distribution<double>* u) {
  char text[240];
  auto draw = [&] { return (*u)(*rng); };
  if (truth == "bushing_damping") {
    std::snprintf(text, sizeof(text), "bushing_damping:d=%.6g",
                  LogUniform(5e4, 3e6, m));
  } else if (truth == "hysteresis") {
    std::snprintf(text, sizeof(text), "hysteresis:force=%.6g,sigma=%.6g",
                  LogUniform(20, 1000, m), LogUniform(1e7, 1e8, draw()));
  } else if (truth == "progressive_stiffness") {
    std::snprintf(text, sizeof(text), "progressive_stiffness:c3=%.6g",
                  LogUniform(1e11, 1e13, m));
  } else if (truth == "actuator_lag") {
    std::snprintf(text, sizeof(text), "actuator_lag:tau=%.6g,dead_time=%.6g",
                  LogUniform(1e-3, 0.05, m), 0.01 * m * draw());
  } else if (truth == "rig_compliance") {
    std::snprintf(text, sizeof(text), "rig_compliance:k=%.6g",
                  LogUniform(1e8, 2e6, m));
  } else if (truth == "sensor_offset") {
    const double f = LogUniform(0.2, 10, m);
    const double x = f * 1e-4 * (2 * draw() - 1);
    const double y = f * 1e-4 * (2 * draw() - 1);
    const double z = f * 1e-4 * (2 * draw() - 1);
    const double toe = f * 2e-4 * (2 * draw() - 1);
    const double camber = f * 2e-4 * (2 * draw() - 1);
    const double caster = f * 2e-4 * (2 * draw() - 1);
    const double scale = 1 + 0.01 * f * (2 * draw() - 1);
    std::snprintf(text, sizeof(text),
                  "sensor_offset:x=%.6g,y=%.6g,z=%.6g,toe=%.6g,camber=%.6g,"
                  "caster=%.6g,scale=%.6g",
                  x, y, z, toe, camber, caster, scale);
  } else {
    return "";
  }
  return text;
}

// A wrong "known" parameter of magnitude m: two in three cases a chassis or
// carrier point moved 1 .. 10 mm in a direction uniform on the sphere, else
// the spring rate off by 2 .. 30 %.
void DrawWrongParameter(const SuspensionParameters<double>& model, double m,
                        std::mt19937_64* rng, BlindCase* c) {
  static const char* kPoints[] = {"O1", "O2", "V1", "V2", "P",
                                  "N1", "N2", "U1", "U2", "Q"};
  if ((*rng)() % 3 != 0) {
    // A point moved 1-10 mm in a direction uniform on the sphere.
    c->parameter = kPoints[(*rng)() % 10];
    std::normal_distribution<double> normal;
    Eigen::Vector3d direction;
    for (int k = 0; k < 3; ++k) direction(k) = normal(*rng);
    c->point_move = direction.normalized() * LogUniform(1e-3, 1e-2, m);
    c->parameter_value = c->point_move.norm();
    for (int k = 0; k < 3; ++k) {
      const std::string name = c->parameter + "." + "xyz"[k];
      c->sets.push_back({name, *FindParameter(model, name) + c->point_move(k)});
    }
    return;
  }
  c->parameter = "k_spring";
  const double error = ((*rng)() % 2 ? 1 : -1) * LogUniform(0.02, 0.3, m);
  c->parameter_value = model.spring.stiffness * (1 + error);
  c->sets.push_back({c->parameter, c->parameter_value});
}

// Where a bushing effect acts: one case in two a single bushing (drawn from
// a stream of its own, so that every other draw is as without placement),
// else every bushing.
void PlaceBushingEffect(std::uint64_t seed, int index, BlindCase* c) {
  std::seed_seq where{seed, static_cast<std::uint64_t>(index),
                      std::uint64_t{0xb5}};
  std::mt19937_64 rng(where);
  const bool single = rng() % 2 == 0;
  const int worn = static_cast<int>(rng() % kNumBushings);
  for (int i = 0; i < kNumBushings; ++i) {
    if (single && i != worn) continue;
    BushingSet one{};
    one[i] = true;
    c->components.push_back(DescribeBushingSet(one));
  }
  if (single) c->effect += ",at=" + c->components.front();
}

// One ramp of a plan's list.
Status LoadRamp(const YamlReader& reader, const YAML::Node& node,
                const std::string& key, BlindDesign* d) {
  KCRIG_RETURN_IF_ERROR(
      reader.InRange(node, key, "phi_deg", -180, 180, &d->phi_deg));
  KCRIG_RETURN_IF_ERROR(reader.InRange(node, key, "z_a", -1, 1, &d->z_a));
  KCRIG_RETURN_IF_ERROR(
      reader.InRange(node, key, "duration", 0.05, 60, &d->duration));
  KCRIG_RETURN_IF_ERROR(reader.InRange(node, key, "hold", 0, 60, &d->hold));
  return reader.InRange(node, key, "return", 0, 60, &d->return_duration);
}

Status LoadRamps(const YamlReader& reader, const YAML::Node& root,
                 const std::string& key, bool required,
                 std::vector<BlindDesign>* ramps) {
  if (!root[key] && !required) return Status::Ok();
  YAML::Node list;
  KCRIG_RETURN_IF_ERROR(reader.Child(root, "", key, &list));
  if (!list.IsSequence() || (required && list.size() == 0) ||
      list.size() > kMaxPlanLogs / 2) {
    return reader.Error(list, key,
                        std::string("expected a list of ") +
                            (required ? "1" : "0") + " to " +
                            std::to_string(kMaxPlanLogs / 2) + " ramps");
  }
  ramps->resize(list.size());
  for (size_t i = 0; i < list.size(); ++i) {
    KCRIG_RETURN_IF_ERROR(LoadRamp(
        reader, list[i], key + "[" + std::to_string(i) + "]", &(*ramps)[i]));
  }
  return Status::Ok();
}

}  // namespace

Status LoadBlindTestPlan(const std::string& file, BlindTestPlan* plan) {
  YamlReader reader(file);
  YAML::Node root;
  KCRIG_RETURN_IF_ERROR(reader.Load(&root));
  for (const auto& entry : root) {
    const std::string key = entry.first.IsScalar() ? entry.first.Scalar() : "?";
    if (key != "training" && key != "holdout") {
      return reader.Error(entry.first, key, "unknown key (training, holdout)");
    }
  }
  BlindTestPlan loaded;
  KCRIG_RETURN_IF_ERROR(
      LoadRamps(reader, root, "training", true, &loaded.training));
  KCRIG_RETURN_IF_ERROR(
      LoadRamps(reader, root, "holdout", false, &loaded.holdout));
  *plan = std::move(loaded);
  return Status::Ok();
}

RampExcitation<double> BlindDesign::Ramp(double fmax) const {
  return {phi_deg * kDegree, z_a, fmax, duration, hold, return_duration};
}

std::string BlindDesign::Arguments() const {
  char text[200];
  std::snprintf(text, sizeof(text),
                "--phi %.3f --z %.4f --duration %.3f --hold %.3f "
                "--return %.3f",
                phi_deg, z_a, duration, hold, return_duration);
  return text;
}

std::string BlindCase::Arguments() const {
  std::string out = effect.empty() ? "" : "--effect " + effect;
  for (const auto& [name, value] : sets) {
    char text[120];
    std::snprintf(text, sizeof(text), " --set %s=%.9g", name.c_str(), value);
    out += text;
  }
  return out;
}

Status DrawBlindCase(int index, std::uint64_t seed,
                     const SuspensionParameters<double>& model,
                     const std::vector<std::string>& classes,
                     const BlindTestPlan& plan, BlindCase* blind_case) {
  const std::vector<std::string>& cycle =
      classes.empty() ? BlindCaseClasses() : classes;
  for (const std::string& name : cycle) {
    const std::vector<std::string>& known = BlindCaseClasses();
    if (std::find(known.begin(), known.end(), name) == known.end()) {
      return Status::Error("unknown class '" + name + "'");
    }
  }
  BlindCase c;
  std::mt19937_64 rng(seed * 1000003 + index);
  std::uniform_real_distribution<double> u(0, 1);
  c.index = index;
  c.truth = cycle[index % cycle.size()];
  c.magnitude = u(rng);
  c.noise_seed = (seed * 1000003 + index) * kMaxPlanLogs;
  BlindDesign drawn[3];
  for (BlindDesign& d : drawn) {
    d.phi_deg = 90 * u(rng);
    d.z_a = -0.5 * u(rng);
    d.duration = 1 + 1.5 * u(rng);
    d.hold = 0.3 * u(rng);
    d.return_duration = 0.6 + 1.2 * u(rng);
  }
  c.training = plan.training.empty()
                   ? std::vector<BlindDesign>{drawn[0], drawn[1]}
                   : plan.training;
  c.holdout =
      plan.training.empty() ? std::vector<BlindDesign>{drawn[2]} : plan.holdout;
  for (int i = 0; i < kNumBushings; ++i) {
    c.sets.push_back({"c_" + std::string(kBushingChassisNames[i]),
                      model.bushings[i].stiffness * (0.9 + 0.2 * u(rng))});
  }
  c.effect = EffectText(c.truth, c.magnitude, &rng, &u);
  if (IsBushingEffect(c.truth)) PlaceBushingEffect(seed, index, &c);
  if (c.truth == "model_parameter") {
    DrawWrongParameter(model, c.magnitude, &rng, &c);
  }
  if (!c.effect.empty()) {
    const Status status = ParseEffect(c.effect, &c.effects);
    if (!status.ok()) return status;
  }
  *blind_case = std::move(c);
  return Status::Ok();
}

SuspensionParameters<double> BlindCasePlant(
    const BlindCase& blind_case, const SuspensionParameters<double>& model) {
  SuspensionParameters<double> plant = model;
  for (const auto& [name, value] : blind_case.sets) {
    if (double* p = FindParameter(&plant, name)) *p = value;
  }
  return plant;
}

}  // namespace kcrig
