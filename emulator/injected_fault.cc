#include "emulator/injected_fault.h"

#include <cmath>
#include <cstdlib>
#include <utility>

#include "rt_core/model/channels.h"

namespace kcrig {
namespace {

constexpr std::pair<const char*, InjectedFault::Kind> kKinds[] = {
    {"late", InjectedFault::Kind::kLate},
    {"stale", InjectedFault::Kind::kStale},
    {"lost", InjectedFault::Kind::kLost},
    {"corrupt", InjectedFault::Kind::kCorrupt},
    {"silent", InjectedFault::Kind::kSilent},
    {"stuck", InjectedFault::Kind::kStuck},
    {"nan", InjectedFault::Kind::kNan},
    {"foreign", InjectedFault::Kind::kForeign},
    {"estop", InjectedFault::Kind::kEstop},
};

constexpr const char* kForceNames[3] = {"Fx", "Fy", "Fz"};

int ChannelIndex(std::string_view name) {
  for (int k = 0; k < kNumChannels; ++k) {
    if (name == kChannelNames[k]) return k;
  }
  for (int k = 0; k < 3; ++k) {
    if (name == kForceNames[k]) return kNumChannels + k;
  }
  return -1;
}

// A whole number within [low, high] or a finite number within them.
bool ParseNumber(const std::string& text, double low, double high, bool whole,
                 double* value) {
  char* end = nullptr;
  *value = std::strtod(text.c_str(), &end);
  return !text.empty() && *end == '\0' && std::isfinite(*value) &&
         *value >= low && *value <= high &&
         (!whole || *value == std::floor(*value));
}

// The keys each kind takes besides `at`.
std::string_view KeyOf(InjectedFault::Kind kind) {
  switch (kind) {
    case InjectedFault::Kind::kLate:
      return "delay";
    case InjectedFault::Kind::kStale:
      return "cycles";
    case InjectedFault::Kind::kStuck:
    case InjectedFault::Kind::kNan:
      return "channel";
    default:
      return "";
  }
}

Status ParseItem(const std::string& where, std::string_view key,
                 const std::string& value, InjectedFault* fault) {
  double number = 0;
  if (key == "at") {
    if (!ParseNumber(value, 0, 1e9, true, &number)) {
      return Status::Error(where + ": must be a cycle, 0 .. 1e9");
    }
    fault->at = static_cast<std::int64_t>(number);
  } else if (key == "delay") {
    if (!ParseNumber(value, 0, 60, false, &number)) {
      return Status::Error(where + ": must be a delay within [0, 60] s");
    }
    fault->delay = number;
  } else if (key == "cycles") {
    if (!ParseNumber(value, 1, 1e6, true, &number)) {
      return Status::Error(where + ": must be a count of cycles, 1 .. 1e6");
    }
    fault->cycles = static_cast<int>(number);
  } else {
    fault->channel = ChannelIndex(value);
    if (fault->channel < 0) {
      return Status::Error(where +
                           ": must be one of x, y, z, toe, camber, caster, "
                           "Fx, Fy, Fz");
    }
  }
  return Status::Ok();
}

}  // namespace

Status ParseInjectedFault(std::string_view text, InjectedFault* fault) {
  const std::string given(text);
  const size_t colon = text.find(':');
  const std::string_view name = text.substr(0, colon);
  *fault = InjectedFault();
  fault->text = given;
  bool known = false;
  for (const auto& [kind_name, kind] : kKinds) {
    if (name == kind_name) {
      fault->kind = kind;
      known = true;
    }
  }
  if (!known) {
    return Status::Error(given + ": unknown fault '" + std::string(name) +
                         "' (one of late, stale, lost, corrupt, silent, "
                         "stuck, nan, foreign, estop)");
  }
  std::string_view rest =
      colon == std::string_view::npos ? "" : text.substr(colon + 1);
  const std::string_view extra = KeyOf(fault->kind);
  bool have_at = false, have_extra = extra.empty() || extra == "cycles";
  while (!rest.empty()) {
    const size_t comma = rest.find(',');
    const std::string_view item = rest.substr(0, comma);
    rest = comma == std::string_view::npos ? "" : rest.substr(comma + 1);
    const std::string where = given + ": '" + std::string(item) + "'";
    const size_t equals = item.find('=');
    const std::string_view key = item.substr(0, equals);
    if (equals == std::string_view::npos || (key != "at" && key != extra)) {
      return Status::Error(
          where + ": expected at=CYCLE" +
          (extra.empty() ? std::string() : ", " + std::string(extra) + "=") +
          (extra.empty() ? "" : "VALUE"));
    }
    KCRIG_RETURN_IF_ERROR(
        ParseItem(where, key, std::string(item.substr(equals + 1)), fault));
    (key == "at" ? have_at : have_extra) = true;
  }
  if (!have_at || !have_extra) {
    return Status::Error(
        given + ": needs at=CYCLE" +
        (extra.empty() ? std::string() : " and " + std::string(extra) + "="));
  }
  return Status::Ok();
}

}  // namespace kcrig
