#include "io_drivers/run_log.h"

#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "nlohmann/json.hpp"

namespace kcrig {
namespace {

// Shortest text that reads back to the same double: logs re-read exactly.
void AppendNumber(double value, std::string* out) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  out->append(buffer, result.ptr);
}

std::string FormatCsv(const RunLog& log) {
  std::string csv = "t,Fx,Fy,Fz,x,y,z,toe,camber,caster";
  if (log.has_commanded_force) csv += ",Fx_cmd,Fy_cmd,Fz_cmd";
  csv += '\n';
  csv.reserve(log.samples.size() * 200);
  for (const LogSample& s : log.samples) {
    AppendNumber(s.t, &csv);
    for (int k = 0; k < 3; ++k) {
      csv += ',';
      AppendNumber(s.force(k), &csv);
    }
    for (int k = 0; k < 6; ++k) {
      csv += ',';
      AppendNumber(s.y(k), &csv);
    }
    if (log.has_commanded_force) {
      for (int k = 0; k < 3; ++k) {
        csv += ',';
        AppendNumber(s.commanded(k), &csv);
      }
    }
    csv += '\n';
  }
  return csv;
}

std::string FormatSidecar(const RunLog& log) {
  const RunMetadata& m = log.metadata;
  nlohmann::ordered_json doc;
  doc["format"] = "kcrig run log 1";
  doc["software_version"] = KCRIG_VERSION;
  doc["units"] = {{"t", "s"},       {"Fx", "N"},    {"Fy", "N"},
                  {"Fz", "N"},      {"x", "m"},     {"y", "m"},
                  {"z", "m"},       {"toe", "rad"}, {"camber", "rad"},
                  {"caster", "rad"}};
  if (log.has_commanded_force) {
    doc["units"]["Fx_cmd"] = "N";
    doc["units"]["Fy_cmd"] = "N";
    doc["units"]["Fz_cmd"] = "N";
  }
  doc["rate_hz"] = m.rate;
  doc["samples"] = log.samples.size();
  doc["excitation"] = {{"type", "linear_ramp"},
                       {"phi_rad", m.phi},
                       {"z_a_m", m.z_a},
                       {"fmax_n", m.fmax},
                       {"tf_s", m.duration}};
  doc["measurement_sigma"] = {{"position_m", m.sigma_position},
                              {"angle_rad", m.sigma_angle}};
  doc["noise"] = {{"added", m.noise_added}, {"seed", m.seed}};
  doc["transport"] = m.transport;
  if (m.synthetic) {
    nlohmann::ordered_json parameters;
    for (const auto& [name, value] : m.truth_parameters) {
      parameters[name] = value;
    }
    doc["truth"] = {{"parameters", parameters}, {"effects", m.truth_effects}};
  }
  return doc.dump(2) + "\n";
}

}  // namespace

std::string SidecarPath(const std::string& csv_path) {
  return std::filesystem::path(csv_path).replace_extension(".json").string();
}

Status WriteFilesAtomically(
    const std::vector<std::pair<std::string, std::string>>& files) {
  std::vector<std::string> temporaries;
  auto remove_temporaries = [&temporaries] {
    for (const std::string& t : temporaries) std::remove(t.c_str());
  };
  for (const auto& [path, content] : files) {
    const std::string temporary =
        path + ".tmp." + std::to_string(static_cast<long>(getpid()));
    std::FILE* file = std::fopen(temporary.c_str(), "wb");
    if (file == nullptr) {
      const std::string reason = std::strerror(errno);
      remove_temporaries();
      return Status::Error(path + ": cannot write: " + reason);
    }
    temporaries.push_back(temporary);
    const bool written =
        std::fwrite(content.data(), 1, content.size(), file) == content.size();
    const bool closed = std::fclose(file) == 0;
    if (!written || !closed) {
      const std::string reason = std::strerror(errno);
      remove_temporaries();
      return Status::Error(path + ": write failed: " + reason);
    }
  }
  for (size_t i = 0; i < files.size(); ++i) {
    if (std::rename(temporaries[i].c_str(), files[i].first.c_str()) != 0) {
      const std::string reason = std::strerror(errno);
      for (size_t k = 0; k < i; ++k) std::remove(files[k].first.c_str());
      remove_temporaries();
      return Status::Error(files[i].first + ": cannot write: " + reason);
    }
  }
  return Status::Ok();
}

Status WriteRunLog(const std::string& csv_path, const RunLog& log) {
  if (std::filesystem::path(csv_path).extension() != ".csv") {
    return Status::Error(csv_path + ": a run log must end in .csv");
  }
  return WriteFilesAtomically({{csv_path, FormatCsv(log)},
                               {SidecarPath(csv_path), FormatSidecar(log)}});
}

}  // namespace kcrig
