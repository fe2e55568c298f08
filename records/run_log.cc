#include "records/run_log.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "base/atomic_files.h"
#include "base/input_file.h"
#include "base/json_reader.h"
#include "nlohmann/json.hpp"
#include "records/internal/run_log_sidecar.h"
#include "records/partial_file.h"

namespace kcrig {
namespace {

constexpr const char* kSidecarFormat = "kcrig run log 1";

// Shortest text that reads back to the same double: logs re-read exactly.
void AppendNumber(double value, std::string* out) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  out->append(buffer, result.ptr);
}

}  // namespace

std::string RunLogCsvHeader(const RunLog& log) {
  std::string csv = log.has_measured_force
                        ? "t,Fx,Fy,Fz,x,y,z,toe,camber,caster"
                        : "t,x,y,z,toe,camber,caster";
  if (log.has_commanded_force) csv += ",Fx_cmd,Fy_cmd,Fz_cmd";
  if (log.has_loop_columns) {
    csv +=
        ",fresh,phase,safety,rig_sample,rig_status,x_model,y_model,z_model,"
        "toe_model,camber_model,caster_model";
  }
  csv += '\n';
  return csv;
}

void AppendRunLogCsvRow(const RunLog& log, const LogSample& s,
                        std::string* csv) {
  AppendNumber(s.t, csv);
  for (int k = 0; log.has_measured_force && k < 3; ++k) {
    *csv += ',';
    AppendNumber(s.force(k), csv);
  }
  for (int k = 0; k < 6; ++k) {
    *csv += ',';
    AppendNumber(s.y(k), csv);
  }
  if (log.has_commanded_force) {
    for (int k = 0; k < 3; ++k) {
      *csv += ',';
      AppendNumber(s.commanded(k), csv);
    }
  }
  if (log.has_loop_columns) {
    *csv += s.fresh ? ",1," : ",0,";
    *csv += s.phase;
    *csv += ',' + std::to_string(s.safety) + ',' +
            std::to_string(s.rig_sample) + ',' + std::to_string(s.rig_status);
    for (int k = 0; k < 6; ++k) {
      *csv += ',';
      AppendNumber(s.predicted(k), csv);
    }
  }
  *csv += '\n';
}

namespace {

std::string FormatCsv(const RunLog& log) {
  std::string csv = RunLogCsvHeader(log);
  csv.reserve(log.samples.size() * 200);
  for (const LogSample& s : log.samples) AppendRunLogCsvRow(log, s, &csv);
  return csv;
}

}  // namespace

std::string FormatSidecar(const RunLog& log, std::int64_t rows) {
  const RunMetadata& m = log.metadata;
  nlohmann::ordered_json doc;
  doc["format"] = kSidecarFormat;
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
  doc["samples"] = rows;
  const RampExcitation<double>& e = m.excitation;
  doc["excitation"] = {{"type", "linear_ramp"},
                       {"phi_rad", e.phi},
                       {"z_a_m", e.z_a},
                       {"fmax_n", e.fmax},
                       {"tf_s", e.duration},
                       {"hold_s", e.hold},
                       {"return_s", e.return_duration}};
  doc["measurement_sigma"] = {{"position_m", m.sigma_position},
                              {"angle_rad", m.sigma_angle}};
  doc["noise"] = {{"added", m.noise_added}, {"seed", m.seed}};
  doc["transport"] = m.transport;
  if (!m.geometry.empty()) doc["geometry"] = m.geometry;
  if (!m.hil_json.empty())
    doc["hil"] = nlohmann::ordered_json::parse(m.hil_json);
  if (m.synthetic) {
    nlohmann::ordered_json parameters;
    for (const auto& [name, value] : m.truth_parameters) {
      parameters[name] = value;
    }
    doc["truth"] = {{"parameters", parameters}, {"effects", m.truth_effects}};
  }
  return doc.dump(2) + "\n";
}

namespace {

constexpr const char* kChannels[] = {"t", "Fx", "Fy",  "Fz",     "x",
                                     "y", "z",  "toe", "camber", "caster"};
constexpr const char* kCommandedChannels[] = {"Fx_cmd", "Fy_cmd", "Fz_cmd"};
constexpr const char* kLoopColumns[] = {
    "safety",  "rig_sample", "rig_status",   "x_model",     "y_model",
    "z_model", "toe_model",  "camber_model", "caster_model"};

std::vector<std::string_view> SplitFields(std::string_view line) {
  std::vector<std::string_view> fields;
  size_t start = 0;
  while (true) {
    const size_t comma = line.find(',', start);
    fields.push_back(line.substr(start, comma - start));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return fields;
}

bool ParseFinite(std::string_view text, double* value) {
  while (!text.empty() && text.front() == ' ') text.remove_prefix(1);
  while (!text.empty() && (text.back() == ' ' || text.back() == '\r')) {
    text.remove_suffix(1);
  }
  const char* end = text.data() + text.size();
  const auto result = std::from_chars(text.data(), end, *value);
  return result.ec == std::errc() && result.ptr == end && std::isfinite(*value);
}

// The value of `column` parsed, finite and within its physical limit.
Status ParseChannel(std::string_view field, const char* column,
                    const std::string& where, double* value) {
  if (!ParseFinite(field, value)) {
    return Status::Error(where + ": column '" + column +
                         "': not a finite number ('" + std::string(field) +
                         "')");
  }
  const double limit = PhysicalLimit(column);
  if (limit > 0 && std::abs(*value) > limit) {
    char text[64];
    std::snprintf(text, sizeof(text), "%g", *value);
    return Status::Error(where + ": column '" + column + "': " + text +
                         " is beyond any rig (" + PhysicalLimitText(column) +
                         ")");
  }
  return Status::Ok();
}

// safety, rig_sample, rig_status (whole numbers in their ranges) and the
// live model prediction of one row.
Status ParseLoopColumns(const std::vector<std::string_view>& fields,
                        const int* column, const std::string& where,
                        LogSample* sample) {
  double values[9];
  for (int k = 0; k < 9; ++k) {
    if (!ParseFinite(fields[column[k]], &values[k])) {
      return Status::Error(where + ": column '" + kLoopColumns[k] +
                           "': not a finite number");
    }
  }
  const double limits[3] = {2, 4294967295.0, 65535};
  for (int k = 0; k < 3; ++k) {
    if (values[k] != std::floor(values[k]) || values[k] < 0 ||
        values[k] > limits[k]) {
      return Status::Error(where + ": column '" + kLoopColumns[k] +
                           "': not a whole number within [0, " +
                           std::to_string(static_cast<long long>(limits[k])) +
                           "]");
    }
  }
  sample->safety = static_cast<int>(values[0]);
  sample->rig_sample = static_cast<std::uint32_t>(values[1]);
  sample->rig_status = static_cast<std::uint16_t>(values[2]);
  for (int k = 0; k < 6; ++k) sample->predicted(k) = values[3 + k];
  return Status::Ok();
}

// The sidecar's format and the kinds of its fields a reader relies on: a
// newer format is refused by name, a sample count must be a whole number.
Status CheckSidecarKinds(const nlohmann::json& doc, const std::string& path,
                         size_t rows) {
  if (doc.contains("format") &&
      (!doc["format"].is_string() || doc["format"] != kSidecarFormat)) {
    return Status::Error(path + ": format " + doc["format"].dump() +
                         ": this kcrig reads \"" + kSidecarFormat + "\"");
  }
  if (doc.contains("samples") && !doc["samples"].is_number_unsigned()) {
    return Status::Error(path + ": samples must be a whole number >= 0 (the " +
                         "CSV has " + std::to_string(rows) + ")");
  }
  const nlohmann::json& ex = doc["excitation"];
  if (ex.contains("type") && ex["type"] != "linear_ramp") {
    return Status::Error(path + ": excitation.type " + ex["type"].dump() +
                         ": only \"linear_ramp\" is known");
  }
  return Status::Ok();
}

}  // namespace

Status ParseSidecar(const nlohmann::json& doc, const std::string& path,
                    size_t rows, double first_t, double last_t,
                    RunMetadata* m) {
  auto number = [&](const nlohmann::json& parent, const char* section,
                    const char* key, double* out) -> Status {
    if (!parent.contains(key) || !parent[key].is_number()) {
      return Status::Error(path + ": " + section + key +
                           ": missing or not a number");
    }
    *out = parent[key].get<double>();
    if (!std::isfinite(*out)) {
      return Status::Error(path + ": " + section + key + ": not finite");
    }
    return Status::Ok();
  };
  if (!doc.is_object() || !doc.contains("excitation") ||
      !doc["excitation"].is_object() || !doc.contains("measurement_sigma") ||
      !doc["measurement_sigma"].is_object()) {
    return Status::Error(path +
                         ": not a kcrig run sidecar (no excitation or "
                         "measurement_sigma)");
  }
  KCRIG_RETURN_IF_ERROR(CheckSidecarKinds(doc, path, rows));
  const nlohmann::json& ex = doc["excitation"];
  const nlohmann::json& sigma = doc["measurement_sigma"];
  RampExcitation<double>* e = &m->excitation;
  for (const Status& status :
       {number(doc, "", "rate_hz", &m->rate),
        number(ex, "excitation.", "phi_rad", &e->phi),
        number(ex, "excitation.", "z_a_m", &e->z_a),
        number(ex, "excitation.", "fmax_n", &e->fmax),
        number(ex, "excitation.", "tf_s", &e->duration),
        number(sigma, "measurement_sigma.", "position_m", &m->sigma_position),
        number(sigma, "measurement_sigma.", "angle_rad", &m->sigma_angle)}) {
    if (!status.ok()) return status;
  }
  if (!(m->rate >= 1 && m->rate <= 1e5)) {
    return Status::Error(path + ": rate_hz must be within [1, 100000] Hz");
  }
  if (!(m->sigma_position > 0 && m->sigma_position <= 0.1) ||
      !(m->sigma_angle > 0 && m->sigma_angle <= 0.2)) {
    return Status::Error(path +
                         ": measurement sigmas must be within (0, 0.1] m "
                         "and (0, 0.2] rad");
  }
  if (!(e->fmax >= 0 && e->fmax <= 1e5)) {
    return Status::Error(path +
                         ": excitation.fmax_n must be within [0, 100000] N");
  }
  if (!(std::abs(e->phi) <= 2 * M_PI + 1e-9)) {
    return Status::Error(path +
                         ": excitation.phi_rad must be within [-2 pi, 2 pi]");
  }
  if (!(std::abs(e->z_a) <= 2)) {
    return Status::Error(path + ": excitation.z_a_m must be within [-2, 2] m");
  }
  if (!(e->duration > 0 && e->duration <= 3600)) {
    return Status::Error(path + ": excitation.tf_s must be within (0, 3600] s");
  }
  if (doc.contains("samples") && doc["samples"].get<size_t>() != rows) {
    return Status::Error(path + ": says " +
                         std::to_string(doc["samples"].get<size_t>()) +
                         " samples, the CSV has " + std::to_string(rows) +
                         " (mismatched sidecar)");
  }
  const double expected_span = (rows - 1) / m->rate;
  if (std::abs((last_t - first_t) - expected_span) > 0.5 / m->rate) {
    return Status::Error(path + ": rate " + std::to_string(m->rate) +
                         " Hz does not match the CSV's time column "
                         "(mismatched sidecar)");
  }
  // Optional: logs written before these existed have neither.
  for (const auto& [key, target] :
       {std::pair{"hold_s", &e->hold}, {"return_s", &e->return_duration}}) {
    if (!ex.contains(key)) continue;
    const Status status = number(ex, "excitation.", key, target);
    if (!status.ok()) return status;
    if (!(*target >= 0 && *target <= 3600)) {
      return Status::Error(path + ": excitation." + key +
                           ": must be within [0, 3600] s");
    }
  }
  if (doc.contains("transport") && doc["transport"].is_string()) {
    m->transport = doc["transport"].get<std::string>();
  }
  if (doc.contains("geometry") && doc["geometry"].is_string()) {
    m->geometry = doc["geometry"].get<std::string>();
  }
  if (doc.contains("noise") && doc["noise"].is_object()) {
    const nlohmann::json& noise = doc["noise"];
    m->noise_added = noise.contains("added") && noise["added"].is_boolean() &&
                     noise["added"].get<bool>();
    if (noise.contains("seed") && noise["seed"].is_number_unsigned()) {
      m->seed = noise["seed"].get<std::uint64_t>();
    }
  }
  return Status::Ok();
}

namespace {

Status ReadSidecar(const std::string& path, size_t rows, double first_t,
                   double last_t, RunMetadata* m) {
  nlohmann::json doc;
  KCRIG_RETURN_IF_ERROR(ReadJsonFile(path, &doc));
  return ParseSidecar(doc, path, rows, first_t, last_t, m);
}

// The whole file, which must end with a whole line.
Status ReadWholeLog(const std::string& csv_path, std::string* text) {
  // An hour at 1 kHz with every column is about 0.6 GB.
  constexpr std::uintmax_t kMaxLogBytes = 1u << 30;
  KCRIG_RETURN_IF_ERROR(CheckInputFile(csv_path, kMaxLogBytes));
  std::ifstream in(csv_path, std::ios::binary);
  if (!in) return Status::Error(csv_path + ": cannot open");
  std::stringstream buffer;
  buffer << in.rdbuf();
  *text = buffer.str();
  if (text->empty()) return Status::Error(csv_path + ": empty file");
  if (text->back() != '\n') {
    const long line = 1 + std::count(text->begin(), text->end(), '\n');
    return Status::Error(csv_path + ":" + std::to_string(line) +
                         ": truncated (the last line is incomplete)");
  }
  return Status::Ok();
}

// Where each column of a run.csv is; -1 when absent.
struct LogColumns {
  // t, Fx, Fy, Fz (absent together: no load cell), x .. caster.
  int channel[10];
  int commanded[3];  // Fx_cmd .. Fz_cmd, all or none
  int fresh = -1;
  int phase = -1;
  int loop[3 + 6];  // the loop's other columns, all or none
};

// The header's columns, checked: none twice, the required ones present, the
// groups complete. Sets which groups `log` has.
Status MapColumns(const std::vector<std::string_view>& header,
                  const std::string& csv_path, LogColumns* columns,
                  RunLog* log) {
  // A column given twice would be read from whichever comes first.
  for (size_t i = 0; i < header.size(); ++i) {
    if (std::find(header.begin(), header.begin() + static_cast<long>(i),
                  header[i]) != header.begin() + static_cast<long>(i)) {
      return Status::Error(csv_path + ":1: column '" + std::string(header[i]) +
                           "' appears twice");
    }
  }
  auto find = [&header](std::string_view name) {
    for (size_t i = 0; i < header.size(); ++i) {
      if (header[i] == name) return static_cast<int>(i);
    }
    return -1;
  };
  int forces_found = 0;
  for (int k = 0; k < 10; ++k) {
    columns->channel[k] = find(kChannels[k]);
    const bool force = k >= 1 && k <= 3;
    forces_found += force && columns->channel[k] >= 0;
    if (columns->channel[k] < 0 && !force) {
      return Status::Error(csv_path + ":1: missing column '" +
                           std::string(kChannels[k]) + "'");
    }
  }
  if (forces_found != 0 && forces_found != 3) {
    return Status::Error(csv_path + ":1: Fx, Fy, Fz must appear together");
  }
  log->has_measured_force = forces_found == 3;
  int commanded_found = 0;
  for (int k = 0; k < 3; ++k) {
    columns->commanded[k] = find(kCommandedChannels[k]);
    commanded_found += columns->commanded[k] >= 0;
  }
  if (commanded_found != 0 && commanded_found != 3) {
    return Status::Error(csv_path +
                         ":1: Fx_cmd, Fy_cmd, Fz_cmd must appear together");
  }
  log->has_commanded_force = commanded_found == 3;
  columns->fresh = find("fresh");
  columns->phase = find("phase");
  // A rig log re-written (kcrig export) keeps the loop's columns.
  int loop_found = 0;
  for (int k = 0; k < 9; ++k) {
    columns->loop[k] = find(kLoopColumns[k]);
    loop_found += columns->loop[k] >= 0;
  }
  log->has_loop_columns =
      loop_found == 9 && columns->fresh >= 0 && columns->phase >= 0;
  return Status::Ok();
}

// One row's sample; `where` (file:line) leads the error.
Status ParseRow(const std::vector<std::string_view>& fields,
                const LogColumns& columns, const RunLog& log,
                const std::string& where, LogSample* sample) {
  double values[10] = {};
  for (int k = 0; k < 10; ++k) {
    if (columns.channel[k] < 0) continue;
    KCRIG_RETURN_IF_ERROR(ParseChannel(fields[columns.channel[k]], kChannels[k],
                                       where, &values[k]));
  }
  sample->t = values[0];
  sample->force << values[1], values[2], values[3];
  sample->y << values[4], values[5], values[6], values[7], values[8], values[9];
  if (log.has_commanded_force) {
    for (int k = 0; k < 3; ++k) {
      KCRIG_RETURN_IF_ERROR(ParseChannel(fields[columns.commanded[k]],
                                         kCommandedChannels[k], where,
                                         &sample->commanded(k)));
    }
  }
  if (columns.fresh >= 0) {
    const std::string_view fresh = fields[columns.fresh];
    if (fresh != "0" && fresh != "1") {
      return Status::Error(where + ": column 'fresh': expected 0 or 1, got '" +
                           std::string(fresh) + "'");
    }
    sample->fresh = fresh == "1";
  }
  if (log.has_loop_columns) {
    KCRIG_RETURN_IF_ERROR(
        ParseLoopColumns(fields, columns.loop, where, sample));
  }
  if (columns.phase >= 0) {
    sample->phase = RunPhaseNamed(fields[columns.phase]);
    if (sample->phase.empty()) {
      return Status::Error(where + ": column 'phase': unknown phase '" +
                           std::string(fields[columns.phase]) + "'");
    }
  }
  return Status::Ok();
}

}  // namespace

Status ReadRunLog(const std::string& csv_path, RunLog* log) {
  std::string text;
  KCRIG_RETURN_IF_ERROR(ReadWholeLog(csv_path, &text));
  std::string_view rest(text);
  auto next_line = [&rest]() {
    const size_t end = rest.find('\n');
    std::string_view line = rest.substr(0, end);
    rest.remove_prefix(end + 1);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    return line;
  };
  const std::vector<std::string_view> header = SplitFields(next_line());
  LogColumns columns;
  KCRIG_RETURN_IF_ERROR(MapColumns(header, csv_path, &columns, log));
  log->samples.clear();
  long line_number = 1;
  while (!rest.empty()) {
    ++line_number;
    const std::string where = csv_path + ":" + std::to_string(line_number);
    const std::vector<std::string_view> fields = SplitFields(next_line());
    if (fields.size() != header.size()) {
      return Status::Error(where + ": expected " +
                           std::to_string(header.size()) + " fields, got " +
                           std::to_string(fields.size()));
    }
    LogSample sample;
    KCRIG_RETURN_IF_ERROR(ParseRow(fields, columns, *log, where, &sample));
    if (!log->samples.empty() && !(sample.t > log->samples.back().t)) {
      return Status::Error(where + ": time " +
                           std::string(fields[columns.channel[0]]) +
                           " s does not increase");
    }
    log->samples.push_back(sample);
  }
  if (log->samples.size() < 2) {
    return Status::Error(csv_path + ": fewer than 2 samples");
  }
  return ReadSidecar(SidecarPath(csv_path), log->samples.size(),
                     log->samples.front().t, log->samples.back().t,
                     &log->metadata);
}

double PhysicalLimit(std::string_view column) {
  if (column.rfind("F", 0) == 0) return 1e6;  // Fx..Fz, Fx_cmd..Fz_cmd
  if (column == "x" || column == "y" || column == "z") return 10;
  if (column == "toe" || column == "camber" || column == "caster") return 7;
  return 0;
}

std::string PhysicalLimitText(std::string_view column) {
  const double limit = PhysicalLimit(column);
  const char* unit = column.rfind("F", 0) == 0 ? "N"
                     : limit == 10             ? "m"
                                               : "rad";
  char text[48];
  std::snprintf(text, sizeof(text), "|value| <= %g %s", limit, unit);
  return text;
}

std::string SidecarPath(const std::string& csv_path) {
  return std::filesystem::path(csv_path).replace_extension(".json").string();
}

Status FinishStreamedRunLog(PartialFile* csv, const RunLog& log,
                            std::int64_t rows) {
  KCRIG_RETURN_IF_ERROR(csv->Close());
  KCRIG_RETURN_IF_ERROR(WriteRunLogSidecar(csv->path(), log, rows));
  const std::string sidecar = SidecarPath(csv->path());
  const Status committed = csv->Commit();
  if (!committed.ok()) std::remove(sidecar.c_str());
  return committed;
}

Status WriteRunLogSidecar(const std::string& csv_path, const RunLog& log,
                          std::int64_t rows) {
  return WriteFilesAtomically(
      {{SidecarPath(csv_path), FormatSidecar(log, rows)}});
}

Status WriteRunLog(const std::string& csv_path, const RunLog& log) {
  if (std::filesystem::path(csv_path).extension() != ".csv") {
    return Status::Error(csv_path + ": a run log must end in .csv");
  }
  return WriteFilesAtomically(
      {{csv_path, FormatCsv(log)},
       {SidecarPath(csv_path),
        FormatSidecar(log, static_cast<std::int64_t>(log.samples.size()))}});
}

}  // namespace kcrig
