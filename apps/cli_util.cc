#include "apps/cli_util.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>

#include "base/atomic_files.h"
#include "hil/rig_config.h"
#include "records/partial_file.h"
#include "records/read_log.h"
#include "records/run_log.h"
#include "rt_core/model/channels.h"

namespace kcrig {

bool ParseFiniteDouble(const std::string& text, double* value) {
  const char* end = text.data() + text.size();
  const auto result = std::from_chars(text.data(), end, *value);
  return result.ec == std::errc() && result.ptr == end && std::isfinite(*value);
}

namespace {

// Whether the whole text is a base-10 integer of type T.
template <typename T>
bool IsDecimalInteger(const std::string& text) {
  T value;
  const char* end = text.data() + text.size();
  const auto result = std::from_chars(text.data(), end, value);
  return result.ec == std::errc() && result.ptr == end;
}

}  // namespace

void RequireDecimalNumbers(CLI::App* app) {
  for (CLI::Option* option : app->get_options()) {
    // "FLOAT", or "FLOAT:<what its checks say>".
    const std::string full = option->get_type_name();
    const std::string type = full.substr(0, full.find(':'));
    if (type != "FLOAT" && type != "INT" && type != "UINT") continue;
    option->check(CLI::Validator(
        [type](std::string& text) -> std::string {
          double unused;
          const bool ok = type == "FLOAT" ? ParseFiniteDouble(text, &unused)
                          : type == "INT"
                              ? IsDecimalInteger<long long>(text)
                              : IsDecimalInteger<unsigned long long>(text);
          if (ok) return std::string();
          return "'" + text + "' is not a " +
                 (type == "FLOAT" ? "finite decimal number"
                  : type == "INT" ? "decimal whole number"
                                  : "decimal whole number >= 0");
        },
        "", "decimal"));
  }
  for (CLI::App* sub : app->get_subcommands({})) RequireDecimalNumbers(sub);
}

Status ParseAssignment(const std::string& option, const std::string& text,
                       std::string* name, double* value) {
  const size_t eq = text.find('=');
  if (eq == std::string::npos || eq == 0) {
    return Status::Error(option + " " + text + ": expected NAME=VALUE");
  }
  *name = text.substr(0, eq);
  const std::string number = text.substr(eq + 1);
  if (!ParseFiniteDouble(number, value)) {
    double parsed = 0;
    const auto result =
        std::from_chars(number.data(), number.data() + number.size(), parsed);
    if (result.ec == std::errc() &&
        result.ptr == number.data() + number.size()) {
      return Status::Error(option + " " + text + ": value must be finite");
    }
    return Status::Error(option + " " + text + ": '" + number +
                         "' is not a number");
  }
  return Status::Ok();
}

Status ApplyParameterAssignment(const std::string& option,
                                const std::string& text,
                                SuspensionParameters<double>* model) {
  std::string name;
  double value = 0;
  KCRIG_RETURN_IF_ERROR(ParseAssignment(option, text, &name, &value));
  double* parameter = FindParameter(model, name);
  if (parameter == nullptr) {
    return Status::Error(option + " " + text + ": unknown parameter '" + name +
                         "' (e.g. c_O1, d_P, k_spring, mass, O1.x)");
  }
  *parameter = value;
  return Status::Ok();
}

std::vector<std::string> SplitList(const std::string& text, char separator) {
  std::vector<std::string> items;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = text.find(separator, start);
    const std::string item = text.substr(start, comma - start);
    if (!item.empty()) items.push_back(item);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return items;
}

Status ParseChannels(const std::string& text, std::vector<int>* channels) {
  channels->clear();
  for (const std::string& name : SplitList(text)) {
    int found = -1;
    for (int k = 0; k < 6; ++k) {
      if (name == kChannelNames[k]) found = k;
    }
    if (found < 0) {
      return Status::Error("--channels: unknown channel '" + name +
                           "' (x, y, z, toe, camber, caster)");
    }
    channels->push_back(found);
  }
  if (channels->empty()) return Status::Error("--channels: empty list");
  return Status::Ok();
}

void AddExcitationOptions(CLI::App* cmd, ExcitationArgs* args) {
  // Sets the optional only when the option is given, within [low, high].
  auto optional_number = [cmd](const char* name, std::optional<double>* target,
                               double low, double high, const char* help) {
    cmd->add_option_function<double>(
           name, [target](const double& value) { *target = value; }, help)
        ->check(CLI::Range(low, high));
  };
  optional_number("--phi", &args->phi_deg, -360, 360,
                  "Force direction in the x-y plane [deg] (default: config)");
  optional_number("--z", &args->z_a, -2, 2,
                  "Acting point height relative to the wheel centre [m]");
  optional_number("--fmax", &args->fmax, 0, 1e5, "Ramp amplitude [N]");
  optional_number("--duration", &args->duration, 1e-3, 3600,
                  "Ramp time tf [s]");
  optional_number("--hold", &args->hold, 0, 3600,
                  "Hold at +Fmax after the ramp [s] (default 0)");
  optional_number("--return", &args->return_duration, 0, 3600,
                  "Return ramp +Fmax -> -Fmax after the hold [s] (default 0: "
                  "none)");
}

RampExcitation<double> ResolveRamp(const ExcitationArgs& args,
                                   const ExperimentConfig& experiment) {
  return {args.phi_deg ? *args.phi_deg * kDegree : experiment.phi,
          args.z_a.value_or(experiment.z_a),
          args.fmax.value_or(experiment.fmax),
          args.duration.value_or(experiment.duration),
          args.hold.value_or(0.0),
          args.return_duration.value_or(0.0)};
}

int CommandError::operator()(const Status& status) const {
  std::fprintf(stderr, "kcrig %s: %s\n", command_.c_str(),
               status.message().c_str());
  return 1;
}

Status CheckOutput(const std::string& option, const std::string& out,
                   const std::vector<std::string>& inputs) {
  if (out.empty()) return Status::Ok();
  const Status replaceable = CheckReplaceable(out);
  if (!replaceable.ok()) {
    return Status::Error(option + " " + replaceable.message());
  }
  namespace fs = std::filesystem;
  std::error_code error;
  const fs::path target = fs::weakly_canonical(out, error);
  if (error) return Status::Ok();  // the writer will say what is wrong
  for (const std::string& input : inputs) {
    std::vector<std::string> read = {input};
    if (fs::path(input).extension() == ".csv") {
      read.push_back(SidecarPath(input));
    }
    for (const std::string& path : read) {
      if (fs::weakly_canonical(path, error) == target && !error) {
        return Status::Error(option + " " + out + ": is also an input (" +
                             path + "); writing it would destroy it");
      }
    }
  }
  return Status::Ok();
}

Status ConfiguredDbc(const KcrigConfig& config, std::string* dbc_file) {
  RigConfig rig;
  const Status status = LoadRigConfig(config.directory, &rig);
  if (status.ok()) *dbc_file = rig.can.dbc_file;
  return status;
}

Status MirrorConfig(InputMirror* mirror, std::string* config_dir) {
  if (config_dir->empty()) *config_dir = DefaultConfigDirectory();
  return mirror->Mirror(config_dir);
}

Status MirrorLogs(InputMirror* mirror, std::vector<std::string>* logs) {
  for (std::string& log : *logs) {
    KCRIG_RETURN_IF_ERROR(mirror->Mirror(&log, {SidecarPath(log)}));
  }
  return Status::Ok();
}

Status LoadLogs(const std::vector<std::string>& paths,
                const KcrigConfig& config,
                std::vector<Experiment>* experiments) {
  std::string dbc_file;
  if (std::any_of(paths.begin(), paths.end(), IsCanBusLog)) {
    const Status status = ConfiguredDbc(config, &dbc_file);
    if (!status.ok()) return status;
  }
  return LoadExperiments(paths, config, dbc_file, experiments);
}

Status ParsePlannedRamp(const std::string& text, const ExperimentConfig& config,
                        RampExcitation<double>* ramp) {
  // Every field given: an empty one would shift the rest.
  std::vector<std::string> items(1);
  for (char c : text) {
    if (c == ',') {
      items.emplace_back();
    } else {
      items.back() += c;
    }
  }
  const std::string where = "--ramp '" + text + "': ";
  if (items.size() < 2 || items.size() > 5) {
    return Status::Error(where +
                         "expected PHI_DEG,Z_M[,TF_S[,HOLD_S[,RETURN_S]]]");
  }
  double v[5] = {0, 0, config.duration, 0, 0};
  for (size_t k = 0; k < items.size(); ++k) {
    if (!ParseFiniteDouble(items[k], &v[k])) {
      return Status::Error(where + "'" + items[k] + "' is not a number");
    }
  }
  const double phi = v[0] * kDegree;
  const Interval& p = config.phi_bounds;
  const Interval& z = config.z_a_bounds;
  if (phi < p.lower - 1e-12 || phi > p.upper + 1e-12 ||
      v[1] < z.lower - 1e-12 || v[1] > z.upper + 1e-12) {
    char bounds[160];
    std::snprintf(bounds, sizeof(bounds),
                  "outside the design bounds of experiment.yaml (phi %g..%g "
                  "deg, z_a %g..%g m)",
                  p.lower / kDegree, p.upper / kDegree, z.lower, z.upper);
    return Status::Error(where + bounds);
  }
  if (!(v[2] > 0) || v[3] < 0 || v[4] < 0) {
    return Status::Error(where +
                         "the ramp time must be positive, hold and "
                         "return not negative");
  }
  *ramp = {phi, v[1], config.fmax, v[2], v[3], v[4]};
  return Status::Ok();
}

Status LoadPlan(const std::vector<std::string>& logs,
                const std::vector<std::string>& ramps,
                const KcrigConfig& config, std::vector<Experiment>* plan) {
  KCRIG_RETURN_IF_ERROR(LoadLogs(logs, config, plan));
  for (const std::string& text : ramps) {
    RampExcitation<double> ramp;
    KCRIG_RETURN_IF_ERROR(ParsePlannedRamp(text, config.experiment, &ramp));
    plan->push_back(PlannedExperiment(ramp, config.experiment));
    plan->back().source = "--ramp '" + text + "'";
  }
  if (plan->empty()) {
    const ExperimentConfig& e = config.experiment;
    plan->push_back(PlannedExperiment(e.Excitation(e.phi, e.z_a), e));
  }
  return Status::Ok();
}

Status LoadPlanInputs(const std::string& config_dir, const std::string& out,
                      const std::vector<std::string>& logs,
                      const std::vector<std::string>& ramps,
                      KcrigConfig* config, std::vector<Experiment>* plan) {
  KCRIG_RETURN_IF_ERROR(LoadConfig(config_dir, config));
  KCRIG_RETURN_IF_ERROR(CheckOutput("--out", out, logs));
  return LoadPlan(logs, ramps, *config, plan);
}

}  // namespace kcrig
