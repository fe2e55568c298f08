#include "records/mat_run_log.h"

#include <matio.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <sstream>
#include <vector>

#include "base/atomic_files.h"
#include "base/input_file.h"
#include "nlohmann/json.hpp"
#include "records/internal/mat5_check.h"
#include "records/internal/run_log_sidecar.h"

namespace kcrig {
namespace {

constexpr const char* kChannelVariables[6] = {"x",   "y",      "z",
                                              "toe", "camber", "caster"};
constexpr const char* kForceVariables[3] = {"Fx", "Fy", "Fz"};
constexpr const char* kCommandedVariables[3] = {"Fx_cmd", "Fy_cmd", "Fz_cmd"};
constexpr const char* kPredictedVariables[6] = {"x_model",      "y_model",
                                                "z_model",      "toe_model",
                                                "camber_model", "caster_model"};

// libmatio reports problems through its log, by default on stderr; kcrig's
// errors are its own one line.
void SilentLog(int, char*) {}

struct MatCloser {
  void operator()(mat_t* mat) const { Mat_Close(mat); }
};
using MatFile = std::unique_ptr<mat_t, MatCloser>;
struct VarFreer {
  void operator()(matvar_t* var) const { Mat_VarFree(var); }
};
using MatVar = std::unique_ptr<matvar_t, VarFreer>;

// ---- Writing -------------------------------------------------------------

Status WriteVariable(mat_t* mat, matvar_t* var, const std::string& path) {
  if (var == nullptr) {
    return Status::Error(path + ": cannot create a MAT variable");
  }
  const MatVar owned(var);
  if (Mat_VarWrite(mat, var, MAT_COMPRESSION_ZLIB) != 0) {
    return Status::Error(path + ": writing variable '" +
                         std::string(var->name) + "' failed");
  }
  return Status::Ok();
}

// A double column vector; matio reads `values` while writing (no copy).
Status WriteColumn(mat_t* mat, const char* name,
                   const std::vector<double>& values, const std::string& path) {
  size_t dims[2] = {values.size(), 1};
  return WriteVariable(
      mat,
      Mat_VarCreate(name, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims,
                    const_cast<double*>(values.data()), MAT_F_DONT_COPY_DATA),
      path);
}

matvar_t* CharRow(const char* name, const std::string& text) {
  size_t dims[2] = {1, text.size()};
  return Mat_VarCreate(name, MAT_C_CHAR, MAT_T_UTF8, 2, dims,
                       const_cast<char*>(text.data()), MAT_F_DONT_COPY_DATA);
}

// The phases as a char matrix, one name per row padded with blanks
// (MATLAB's char matrix; cellstr(phase) gives the names): one array, where
// a cell per sample would cost every reader an array per sample.
Status WritePhases(mat_t* mat, const RunLog& log, const std::string& path) {
  const size_t rows = log.samples.size();
  size_t width = 1;
  for (const LogSample& s : log.samples)
    width = std::max(width, s.phase.size());
  std::string chars(rows * width, ' ');  // column-major
  for (size_t j = 0; j < rows; ++j) {
    const std::string_view name = log.samples[j].phase;
    for (size_t k = 0; k < name.size(); ++k) chars[j + rows * k] = name[k];
  }
  size_t dims[2] = {rows, width};
  return WriteVariable(mat,
                       Mat_VarCreate("phase", MAT_C_CHAR, MAT_T_UTF8, 2, dims,
                                     chars.data(), MAT_F_DONT_COPY_DATA),
                       path);
}

// Every column of `log` as Write in the CSV's order.
Status WriteColumns(mat_t* mat, const RunLog& log, const std::string& path) {
  auto column = [&](const std::function<double(const LogSample&)>& get) {
    std::vector<double> values;
    values.reserve(log.samples.size());
    for (const LogSample& s : log.samples) values.push_back(get(s));
    return values;
  };
  KCRIG_RETURN_IF_ERROR(WriteColumn(
      mat, "t", column([](const LogSample& s) { return s.t; }), path));
  for (int k = 0; log.has_measured_force && k < 3; ++k) {
    KCRIG_RETURN_IF_ERROR(WriteColumn(
        mat, kForceVariables[k],
        column([k](const LogSample& s) { return s.force(k); }), path));
  }
  for (int k = 0; k < 6; ++k) {
    KCRIG_RETURN_IF_ERROR(
        WriteColumn(mat, kChannelVariables[k],
                    column([k](const LogSample& s) { return s.y(k); }), path));
  }
  for (int k = 0; log.has_commanded_force && k < 3; ++k) {
    KCRIG_RETURN_IF_ERROR(WriteColumn(
        mat, kCommandedVariables[k],
        column([k](const LogSample& s) { return s.commanded(k); }), path));
  }
  if (!log.has_loop_columns) return Status::Ok();
  KCRIG_RETURN_IF_ERROR(WriteColumn(
      mat, "fresh",
      column([](const LogSample& s) { return s.fresh ? 1.0 : 0.0; }), path));
  KCRIG_RETURN_IF_ERROR(WritePhases(mat, log, path));
  KCRIG_RETURN_IF_ERROR(
      WriteColumn(mat, "safety",
                  column([](const LogSample& s) { return s.safety; }), path));
  KCRIG_RETURN_IF_ERROR(WriteColumn(
      mat, "rig_sample",
      column([](const LogSample& s) { return s.rig_sample; }), path));
  KCRIG_RETURN_IF_ERROR(WriteColumn(
      mat, "rig_status",
      column([](const LogSample& s) { return s.rig_status; }), path));
  for (int k = 0; k < 6; ++k) {
    KCRIG_RETURN_IF_ERROR(WriteColumn(
        mat, kPredictedVariables[k],
        column([k](const LogSample& s) { return s.predicted(k); }), path));
  }
  return Status::Ok();
}

// The MAT-file's bytes, written by libmatio through a temporary file.
Status FormatMat(const RunLog& log, const std::string& path,
                 std::string* bytes) {
  std::string temp =
      (std::filesystem::temp_directory_path() / "kcrig-mat-XXXXXX").string();
  const int fd = mkstemp(temp.data());
  if (fd < 0) return Status::Error(path + ": cannot create a temporary file");
  close(fd);
  Status status;
  {
    const MatFile mat(Mat_CreateVer(temp.c_str(), nullptr, MAT_FT_MAT5));
    if (mat == nullptr) {
      status = Status::Error(path + ": cannot create a MAT-file");
    } else {
      status = WriteColumns(mat.get(), log, path);
      if (status.ok()) {
        const std::string sidecar =
            FormatSidecar(log, static_cast<std::int64_t>(log.samples.size()));
        status = WriteVariable(mat.get(), CharRow("sidecar", sidecar), path);
      }
    }
  }
  if (status.ok()) {
    std::ifstream in(temp, std::ios::binary);
    std::stringstream buffer;
    buffer << in.rdbuf();
    *bytes = buffer.str();
    if (!in.good() && !in.eof()) status = Status::Error(path + ": read back");
  }
  std::filesystem::remove(temp);
  return status;
}

// ---- Reading -------------------------------------------------------------

// `bytes` in a new file of the temporary directory, removed with this.
class PrivateCopy {
 public:
  explicit PrivateCopy(const std::string& bytes) {
    std::string path =
        (std::filesystem::temp_directory_path() / "kcrig-mat-XXXXXX").string();
    const int fd = mkstemp(path.data());
    if (fd < 0) return;
    size_t written = 0;
    while (written < bytes.size()) {
      const ssize_t n =
          write(fd, bytes.data() + written, bytes.size() - written);
      if (n <= 0) break;
      written += static_cast<size_t>(n);
    }
    close(fd);
    if (written == bytes.size()) {
      path_ = path;
    } else {
      std::filesystem::remove(path);
    }
  }
  ~PrivateCopy() {
    if (!path_.empty()) std::filesystem::remove(path_);
  }
  PrivateCopy(const PrivateCopy&) = delete;
  PrivateCopy& operator=(const PrivateCopy&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// The elements of a real numeric array as doubles; false for any other
// class.
bool NumericValues(const matvar_t& var, std::vector<double>* out) {
  if (var.isComplex || var.rank != 2) return false;
  const size_t n = var.dims[0] * var.dims[1];
  out->resize(n);
  if (n == 0) return true;
  if (var.data == nullptr) return false;
  auto copy = [&](auto* data) {
    for (size_t i = 0; i < n; ++i) (*out)[i] = static_cast<double>(data[i]);
  };
  switch (var.class_type) {
    case MAT_C_DOUBLE:
      copy(static_cast<const double*>(var.data));
      break;
    case MAT_C_SINGLE:
      copy(static_cast<const float*>(var.data));
      break;
    case MAT_C_INT8:
      copy(static_cast<const std::int8_t*>(var.data));
      break;
    case MAT_C_UINT8:
      copy(static_cast<const std::uint8_t*>(var.data));
      break;
    case MAT_C_INT16:
      copy(static_cast<const std::int16_t*>(var.data));
      break;
    case MAT_C_UINT16:
      copy(static_cast<const std::uint16_t*>(var.data));
      break;
    case MAT_C_INT32:
      copy(static_cast<const std::int32_t*>(var.data));
      break;
    case MAT_C_UINT32:
      copy(static_cast<const std::uint32_t*>(var.data));
      break;
    case MAT_C_INT64:
      copy(static_cast<const std::int64_t*>(var.data));
      break;
    case MAT_C_UINT64:
      copy(static_cast<const std::uint64_t*>(var.data));
      break;
    default:
      return false;
  }
  return true;
}

// Character `i` of a char array's data (ASCII), or -1.
int CharAt(const matvar_t& var, size_t i) {
  unsigned code = 0;
  switch (var.data_type) {
    case MAT_T_UINT8:
    case MAT_T_UTF8:
    case MAT_T_INT8:
      code = static_cast<const unsigned char*>(var.data)[i];
      break;
    case MAT_T_UINT16:
    case MAT_T_UTF16:
      code = static_cast<const std::uint16_t*>(var.data)[i];
      break;
    default:
      return -1;
  }
  return code <= 127 ? static_cast<int>(code) : -1;
}

// A char array's text (ASCII: the sidecar's JSON, the phase names); false
// for any other class or a non-ASCII character.
bool Text(const matvar_t& var, std::string* out) {
  if (var.class_type != MAT_C_CHAR || var.rank != 2) return false;
  const size_t n = var.dims[0] * var.dims[1];
  out->clear();
  if (n == 0) return true;
  if (var.data == nullptr || (var.dims[0] != 1 && var.dims[1] != 1)) {
    return false;
  }
  for (size_t i = 0; i < n; ++i) {
    const int c = CharAt(var, i);
    if (c < 0) return false;
    out->push_back(static_cast<char>(c));
  }
  return true;
}

// `rows` names from a char matrix (rows x width, blank-padded, as kcrig,
// MATLAB and SciPy write one) or a cell array of char rows.
bool PhaseNames(const matvar_t& var, size_t rows,
                std::vector<std::string>* names) {
  names->assign(rows, "");
  if (var.rank != 2) return false;
  if (var.class_type == MAT_C_CELL) {
    if (var.dims[0] * var.dims[1] != rows) return false;
    for (size_t j = 0; j < rows; ++j) {
      const matvar_t* cell =
          Mat_VarGetCell(const_cast<matvar_t*>(&var), static_cast<int>(j));
      if (cell == nullptr || !Text(*cell, &(*names)[j])) return false;
    }
    return true;
  }
  if (var.class_type != MAT_C_CHAR || var.dims[0] != rows ||
      var.data == nullptr) {
    return false;
  }
  const size_t width = var.dims[1];
  for (size_t j = 0; j < rows; ++j) {
    std::string& name = (*names)[j];
    for (size_t k = 0; k < width; ++k) {
      const int c = CharAt(var, j + rows * k);
      if (c < 0) return false;
      name.push_back(static_cast<char>(c));
    }
    name.erase(name.find_last_not_of(' ') + 1);
  }
  return true;
}

class MatReader {
 public:
  MatReader(mat_t* mat, std::string path) : mat_(mat), path_(std::move(path)) {}

  // Variable `name` as a vector of `rows` finite values (rows 0: whatever
  // the first vector's length); absent: `present` false, or an error when
  // `required`.
  Status Vector(const char* name, bool required, size_t* rows,
                std::vector<double>* values, bool* present = nullptr) {
    const MatVar var(Mat_VarRead(mat_, name));
    if (present != nullptr) *present = var != nullptr;
    if (var == nullptr) {
      return required ? Error(name, "missing (or the file is cut short)")
                      : Status::Ok();
    }
    if (var->rank != 2 || (var->dims[0] != 1 && var->dims[1] != 1) ||
        !NumericValues(*var, values)) {
      return Error(name, "must be a real numeric vector");
    }
    if (*rows == 0) *rows = values->size();
    if (values->size() != *rows) {
      return Error(name, "has " + std::to_string(values->size()) +
                             " elements, 't' has " + std::to_string(*rows));
    }
    const double limit = PhysicalLimit(name);
    for (size_t j = 0; j < values->size(); ++j) {
      if (!std::isfinite((*values)[j])) {
        return Error(name, "element " + std::to_string(j + 1) +
                               " is not a finite number");
      }
      if (limit > 0 && std::abs((*values)[j]) > limit) {
        return Error(name, "element " + std::to_string(j + 1) +
                               " is beyond any rig (" +
                               PhysicalLimitText(name) + ")");
      }
    }
    return Status::Ok();
  }

  Status Phases(size_t rows, std::vector<std::string_view>* phases,
                bool* present) {
    const MatVar var(Mat_VarRead(mat_, "phase"));
    *present = var != nullptr;
    if (var == nullptr) return Status::Ok();
    std::vector<std::string> names;
    if (!PhaseNames(*var, rows, &names)) {
      return Error("phase", "must be a char matrix (or a cell array) of " +
                                std::to_string(rows) + " phase names");
    }
    phases->assign(rows, {});
    for (size_t j = 0; j < rows; ++j) {
      (*phases)[j] = RunPhaseNamed(names[j]);
      if ((*phases)[j].empty()) {
        return Error("phase", "element " + std::to_string(j + 1) +
                                  " is not a phase name");
      }
    }
    return Status::Ok();
  }

  Status Sidecar(std::string* text) {
    const MatVar var(Mat_VarRead(mat_, "sidecar"));
    if (var == nullptr) return Error("sidecar", "missing");
    if (!Text(*var, text)) return Error("sidecar", "must be an ASCII char row");
    return Status::Ok();
  }

  Status Error(const std::string& variable, const std::string& what) const {
    return Status::Error(path_ + ": variable '" + variable + "': " + what);
  }

 private:
  mat_t* mat_;
  std::string path_;
};

Status ReadSamples(MatReader& reader, RunLog* log) {
  size_t rows = 0;
  std::vector<double> t;
  KCRIG_RETURN_IF_ERROR(reader.Vector("t", true, &rows, &t));
  if (rows < 2) return reader.Error("t", "fewer than 2 samples");
  for (size_t j = 1; j < rows; ++j) {
    if (!(t[j] > t[j - 1])) {
      return reader.Error(
          "t", "element " + std::to_string(j + 1) + " does not increase");
    }
  }
  log->samples.assign(rows, LogSample());
  for (size_t j = 0; j < rows; ++j) log->samples[j].t = t[j];
  std::vector<double> values;
  int forces = 0, commanded = 0;
  for (int k = 0; k < 3; ++k) {
    bool present = false;
    KCRIG_RETURN_IF_ERROR(
        reader.Vector(kForceVariables[k], false, &rows, &values, &present));
    for (size_t j = 0; present && j < rows; ++j) {
      log->samples[j].force(k) = values[j];
    }
    forces += present;
    KCRIG_RETURN_IF_ERROR(
        reader.Vector(kCommandedVariables[k], false, &rows, &values, &present));
    for (size_t j = 0; present && j < rows; ++j) {
      log->samples[j].commanded(k) = values[j];
    }
    commanded += present;
  }
  if (forces % 3 != 0) return reader.Error("Fx", "Fx, Fy, Fz go together");
  if (commanded % 3 != 0) {
    return reader.Error("Fx_cmd", "Fx_cmd, Fy_cmd, Fz_cmd go together");
  }
  log->has_measured_force = forces == 3;
  log->has_commanded_force = commanded == 3;
  for (int k = 0; k < 6; ++k) {
    KCRIG_RETURN_IF_ERROR(
        reader.Vector(kChannelVariables[k], true, &rows, &values));
    for (size_t j = 0; j < rows; ++j) log->samples[j].y(k) = values[j];
  }
  bool present = false;
  KCRIG_RETURN_IF_ERROR(
      reader.Vector("fresh", false, &rows, &values, &present));
  for (size_t j = 0; present && j < rows; ++j) {
    if (values[j] != 0 && values[j] != 1) {
      return reader.Error(
          "fresh", "element " + std::to_string(j + 1) + " is neither 0 nor 1");
    }
    log->samples[j].fresh = values[j] == 1;
  }
  const bool has_fresh = present;
  std::vector<std::string_view> phases;
  KCRIG_RETURN_IF_ERROR(reader.Phases(rows, &phases, &present));
  for (size_t j = 0; present && j < rows; ++j) {
    log->samples[j].phase = phases[j];
  }
  bool loop = has_fresh && present;
  // Whole numbers within their fields' ranges (a cast of anything else
  // would be undefined).
  const char* counters[3] = {"safety", "rig_sample", "rig_status"};
  const double limits[3] = {2, 4294967295.0, 65535};
  for (int k = 0; k < 3; ++k) {
    KCRIG_RETURN_IF_ERROR(
        reader.Vector(counters[k], false, &rows, &values, &present));
    loop = loop && present;
    for (size_t j = 0; present && j < rows; ++j) {
      const double v = values[j];
      if (v != std::floor(v) || v < 0 || v > limits[k]) {
        return reader.Error(counters[k],
                            "element " + std::to_string(j + 1) +
                                " is not a whole number in its range");
      }
      LogSample& s = log->samples[j];
      if (k == 0) s.safety = static_cast<int>(v);
      if (k == 1) s.rig_sample = static_cast<std::uint32_t>(v);
      if (k == 2) s.rig_status = static_cast<std::uint16_t>(v);
    }
  }
  for (int k = 0; k < 6; ++k) {
    KCRIG_RETURN_IF_ERROR(
        reader.Vector(kPredictedVariables[k], false, &rows, &values, &present));
    loop = loop && present;
    for (size_t j = 0; present && j < rows; ++j) {
      log->samples[j].predicted(k) = values[j];
    }
  }
  log->has_loop_columns = loop;
  return Status::Ok();
}

}  // namespace

bool IsMatRunLog(const std::string& path) {
  return std::filesystem::path(path).extension() == ".mat";
}

Status WriteMatRunLog(const std::string& mat_path, const RunLog& log) {
  Mat_LogInitFunc("kcrig", SilentLog);
  std::string bytes;
  KCRIG_RETURN_IF_ERROR(FormatMat(log, mat_path, &bytes));
  return WriteFilesAtomically({{mat_path, bytes}});
}

Status ReadMatRunLog(const std::string& mat_path, RunLog* log) {
  constexpr std::uintmax_t kMaxLogBytes = 1u << 30;
  KCRIG_RETURN_IF_ERROR(CheckInputFile(mat_path, kMaxLogBytes));
  // libmatio allocates what the file declares: its structure is checked
  // first.
  std::ifstream in(mat_path, std::ios::binary);
  std::stringstream bytes;
  bytes << in.rdbuf();
  if (!in.good() && !in.eof()) return Status::Error(mat_path + ": cannot read");
  KCRIG_RETURN_IF_ERROR(
      CheckMat5Structure(bytes.str(), mat_path, kMaxLogBytes));
  // libmatio reads the bytes checked, from a private copy: the file at
  // mat_path may change in between (still being written, replaced).
  const PrivateCopy copy(bytes.str());
  if (copy.path().empty()) {
    return Status::Error(mat_path + ": cannot make a private copy to read");
  }
  Mat_LogInitFunc("kcrig", SilentLog);
  const MatFile mat(Mat_Open(copy.path().c_str(), MAT_ACC_RDONLY));
  if (mat == nullptr || Mat_GetVersion(mat.get()) != MAT_FT_MAT5) {
    return Status::Error(mat_path + ": not a readable MAT-file");
  }
  *log = RunLog();
  MatReader reader(mat.get(), mat_path);
  KCRIG_RETURN_IF_ERROR(ReadSamples(reader, log));
  std::string text;
  KCRIG_RETURN_IF_ERROR(reader.Sidecar(&text));
  const nlohmann::json doc = nlohmann::json::parse(text, nullptr, false);
  if (doc.is_discarded()) {
    return reader.Error("sidecar", "not JSON (run.json's text)");
  }
  return ParseSidecar(doc, mat_path + ": variable 'sidecar'",
                      log->samples.size(), log->samples.front().t,
                      log->samples.back().t, &log->metadata);
}

}  // namespace kcrig
