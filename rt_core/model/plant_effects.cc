#include "rt_core/model/plant_effects.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "rt_core/model/channels.h"

namespace kcrig {
namespace {

// A parameter's physical range: within [low, high], `low` itself excluded
// when `open_low` (a stiffness, a time constant: > 0). The bounds are
// what a suspension rig can show, far beyond it on both sides; a value
// outside is a typo or a unit slip (1 m of sensor offset, 1e-300 N/m),
// never an effect to simulate.
struct Key {
  std::string_view name;
  double* value;
  double low, high;
  bool open_low;
  std::string_view unit;
};

std::vector<Key> KeysOf(std::string_view effect, PlantEffects* e) {
  if (effect == "bushing_damping") {
    return {{"d", &e->bushing_damping.d, 0, 1e8, true, "N s/m"}};
  }
  if (effect == "hysteresis") {
    return {{"force", &e->hysteresis.force, 0, 1e5, true, "N"},
            {"sigma", &e->hysteresis.sigma, 0, 1e12, true, "N/m"}};
  }
  if (effect == "progressive_stiffness") {
    return {{"c3", &e->progressive_stiffness.c3, -1e16, 1e16, false, "N/m^3"},
            {"c2", &e->progressive_stiffness.c2, -1e13, 1e13, false, "N/m^2"},
            {"a2", &e->progressive_stiffness.a2, -1e13, 1e13, false, "N/m^2"}};
  }
  if (effect == "actuator_lag") {
    return {{"tau", &e->actuator_lag.tau, 0, 1, true, "s"},
            {"dead_time", &e->actuator_lag.dead_time, 0, 0.5, false, "s"}};
  }
  if (effect == "rig_compliance") {
    return {{"k", &e->rig_compliance.k, 1e4, 1e12, false, "N/m"},
            {"k_rot", &e->rig_compliance.k_rot, 1e2, 1e10, false, "N m/rad"}};
  }
  if (effect == "sensor_offset") {
    PlantEffects::SensorOffset& s = e->sensor_offset;
    return {{"x", &s.offset(0), -0.05, 0.05, false, "m"},
            {"y", &s.offset(1), -0.05, 0.05, false, "m"},
            {"z", &s.offset(2), -0.05, 0.05, false, "m"},
            {"toe", &s.offset(3), -0.1, 0.1, false, "rad"},
            {"camber", &s.offset(4), -0.1, 0.1, false, "rad"},
            {"caster", &s.offset(5), -0.1, 0.1, false, "rad"},
            {"scale", &s.scale, 0.5, 2, false, "-"}};
  }
  return {};
}

// "must be within (0, 1e+08] N s/m"
std::string RangeText(const Key& key) {
  char text[96];
  std::snprintf(text, sizeof(text), "must be a number within %c%g, %g] %s",
                key.open_low ? '(' : '[', key.low, key.high,
                std::string(key.unit).c_str());
  return text;
}

bool* EnabledFlag(std::string_view effect, PlantEffects* e) {
  if (effect == "bushing_damping") return &e->bushing_damping.enabled;
  if (effect == "hysteresis") return &e->hysteresis.enabled;
  if (effect == "progressive_stiffness") {
    return &e->progressive_stiffness.enabled;
  }
  if (effect == "actuator_lag") return &e->actuator_lag.enabled;
  if (effect == "rig_compliance") return &e->rig_compliance.enabled;
  if (effect == "sensor_offset") return &e->sensor_offset.enabled;
  return nullptr;
}

std::string Names() {
  std::string names;
  for (std::string_view name : kEffectNames) {
    if (!names.empty()) names += ", ";
    names += name;
  }
  return names;
}

// Parses "PREFIX:A+PREFIX:B" over `names` into flags; an unknown
// component's error lists the known ones.
template <size_t N>
Status ParseComponents(std::string_view text, std::string_view prefix,
                       const std::array<std::string_view, N>& names,
                       std::array<bool, N>* set) {
  std::array<bool, N> parsed{};
  while (true) {
    const size_t plus = text.find('+');
    const std::string_view component = text.substr(0, plus);
    size_t found = N;
    for (size_t i = 0; i < N; ++i) {
      if (component.substr(0, prefix.size()) == prefix &&
          component.substr(prefix.size()) == names[i]) {
        found = i;
      }
    }
    if (found == N) {
      std::string known;
      for (size_t i = 0; i < N; ++i) {
        known += (i == 0       ? ""
                  : i + 1 == N ? " or "
                               : ", ") +
                 std::string(prefix) + std::string(names[i]);
      }
      return Status::Error("unknown component '" + std::string(component) +
                           "' (" + known + ", joined by +)");
    }
    parsed[found] = true;
    if (plus == std::string_view::npos) break;
    text = text.substr(plus + 1);
  }
  *set = parsed;
  return Status::Ok();
}

template <size_t N>
std::string DescribeComponents(std::string_view prefix,
                               const std::array<std::string_view, N>& names,
                               const std::array<bool, N>& set) {
  std::string text;
  for (size_t i = 0; i < N; ++i) {
    if (!set[i]) continue;
    text +=
        (text.empty() ? "" : "+") + std::string(prefix) + std::string(names[i]);
  }
  return text;
}

std::array<std::string_view, kNumBushings> BushingNames() {
  std::array<std::string_view, kNumBushings> names;
  for (int i = 0; i < kNumBushings; ++i) names[i] = kBushingChassisNames[i];
  return names;
}

std::array<std::string_view, 6> ChannelNames() {
  std::array<std::string_view, 6> names;
  for (int k = 0; k < 6; ++k) names[k] = kChannelNames[k];
  return names;
}

}  // namespace

Status ParseBushingSet(std::string_view text, BushingSet* at) {
  return ParseComponents(text, kBushingComponent, BushingNames(), at);
}

std::string DescribeBushingSet(const BushingSet& at) {
  return DescribeComponents(kBushingComponent, BushingNames(), at);
}

Status ParseFixtureAxes(std::string_view text, FixtureAxes* axes) {
  return ParseComponents(text, kFixtureComponent, kFixtureAxisNames, axes);
}

std::string DescribeFixtureAxes(const FixtureAxes& axes) {
  return DescribeComponents(kFixtureComponent, kFixtureAxisNames, axes);
}

Status ParseActuatorAxes(std::string_view text, ActuatorAxes* axes) {
  return ParseComponents(text, kActuatorComponent, kActuatorAxisNames, axes);
}

std::string DescribeActuatorAxes(const ActuatorAxes& axes) {
  return DescribeComponents(kActuatorComponent, kActuatorAxisNames, axes);
}

Status ParseSensorChannels(std::string_view text, SensorChannels* channels) {
  return ParseComponents(text, kSensorComponent, ChannelNames(), channels);
}

std::string DescribeSensorChannels(const SensorChannels& channels) {
  return DescribeComponents(kSensorComponent, ChannelNames(), channels);
}

Status ParseEffect(std::string_view text, PlantEffects* effects) {
  const size_t colon = text.find(':');
  const std::string_view name = text.substr(0, colon);
  bool* enabled = EnabledFlag(name, effects);
  if (enabled == nullptr) {
    return Status::Error(std::string(text) + ": unknown effect '" +
                         std::string(name) + "' (one of " + Names() + ")");
  }
  PlantEffects parsed = *effects;
  std::vector<Key> keys = KeysOf(name, &parsed);
  std::string_view rest =
      colon == std::string_view::npos ? "" : text.substr(colon + 1);
  bool rotation_given = false;
  std::vector<std::string_view> given;
  while (!rest.empty()) {
    const size_t comma = rest.find(',');
    const std::string_view item = rest.substr(0, comma);
    rest = comma == std::string_view::npos ? "" : rest.substr(comma + 1);
    const size_t equals = item.find('=');
    const std::string where =
        std::string(text) + ": '" + std::string(item) + "'";
    if (equals == std::string_view::npos) {
      return Status::Error(where + ": expected key=value");
    }
    const std::string_view key = item.substr(0, equals);
    const std::string value_text(item.substr(equals + 1));
    BushingSet* at = PlacementOf(name, &parsed);
    const bool fixture = name == "rig_compliance";
    const bool actuator = name == "actuator_lag";
    if (key == "at" && (at != nullptr || fixture || actuator)) {
      const Status status =
          fixture    ? ParseFixtureAxes(value_text, &parsed.rig_compliance.at)
          : actuator ? ParseActuatorAxes(value_text, &parsed.actuator_lag.at)
                     : ParseBushingSet(value_text, at);
      if (!status.ok()) return Status::Error(where + ": " + status.message());
      continue;
    }
    Key* match = nullptr;
    for (Key& k : keys) {
      if (k.name == key) match = &k;
    }
    if (match == nullptr) {
      std::string allowed;
      for (const Key& k : keys) {
        allowed += (allowed.empty() ? "" : ", ") + std::string(k.name);
      }
      if (at != nullptr || fixture || actuator) allowed += ", at";
      return Status::Error(where + ": unknown parameter of " +
                           std::string(name) + " (one of " + allowed + ")");
    }
    if (std::find(given.begin(), given.end(), key) != given.end()) {
      return Status::Error(where + ": " + std::string(key) + " given twice");
    }
    given.push_back(key);
    char* end = nullptr;
    const double value = std::strtod(value_text.c_str(), &end);
    const bool in_range =
        value <= match->high &&
        (match->open_low ? value > match->low : value >= match->low);
    if (value_text.empty() || *end != '\0' || !std::isfinite(value) ||
        !in_range) {
      return Status::Error(where + ": " + RangeText(*match));
    }
    *match->value = value;
    rotation_given = rotation_given || key == "k_rot";
  }
  const FixtureAxes& axes = parsed.rig_compliance.at;
  if (rotation_given && !axes[3] && !axes[4]) {
    return Status::Error(std::string(text) +
                         ": k_rot needs a rotational axis in at "
                         "(fixture:rx or fixture:ry)");
  }
  *EnabledFlag(name, &parsed) = true;
  *effects = parsed;
  return Status::Ok();
}

std::vector<std::string> DescribeEffects(const PlantEffects& effects) {
  PlantEffects copy = effects;
  std::vector<std::string> out;
  for (std::string_view name : kEffectNames) {
    if (!*EnabledFlag(name, &copy)) continue;
    std::string text(name);
    char separator = ':';
    const FixtureAxes& axes = copy.rig_compliance.at;
    const bool rotates = axes[3] || axes[4];
    for (const Key& k : KeysOf(name, &copy)) {
      // A mount that does not rotate says so by leaving k_rot out, a
      // purely cubic stiffening by leaving c2 and a2 out.
      if (k.name == "k_rot" && !rotates) continue;
      if (k.name == "k" && !axes[0] && !axes[1] && !axes[2]) continue;
      if ((k.name == "c2" || k.name == "a2") && *k.value == 0) continue;
      char value[32];
      std::snprintf(value, sizeof(value), "%.6g", *k.value);
      text += separator + std::string(k.name) + "=" + value;
      separator = ',';
    }
    const BushingSet* at = PlacementOf(name, &copy);
    if (at != nullptr && *at != kEveryBushing) {
      text += ",at=" + DescribeBushingSet(*at);
    }
    if (name == "rig_compliance" && axes != kTranslationalAxes) {
      text += ",at=" + DescribeFixtureAxes(axes);
    }
    if (name == "actuator_lag" && copy.actuator_lag.at != kEveryActuator) {
      text += ",at=" + DescribeActuatorAxes(copy.actuator_lag.at);
    }
    out.push_back(text);
  }
  return out;
}

}  // namespace kcrig
