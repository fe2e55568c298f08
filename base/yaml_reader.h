// Reads one YAML file and turns every problem into one line
// "file:line: key: what" (e.g. "config/model.yaml:14: bushings.O1.stiffness:
// must be > 0"). Each library loads the config sections it owns through it.
#ifndef KCRIG_BASE_YAML_READER_H_
#define KCRIG_BASE_YAML_READER_H_

#include <cmath>
#include <cstdio>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "Eigen/Core"
#include "base/input_file.h"
#include "base/status.h"
#include "yaml-cpp/yaml.h"

namespace kcrig {

// Walks one YAML document and turns every problem into "file:line: key: what".
class YamlReader {
 public:
  explicit YamlReader(std::string file) : file_(std::move(file)) {}

  Status Load(YAML::Node* root) {
    constexpr std::uintmax_t kMaxYamlBytes = 1u << 20;
    KCRIG_RETURN_IF_ERROR(CheckInputFile(file_, kMaxYamlBytes));
    try {
      *root = YAML::LoadFile(file_);
    } catch (const YAML::BadFile&) {
      return Status::Error(file_ + ": cannot open");
    } catch (const YAML::Exception& e) {
      return Status::Error(file_ + ":" + std::to_string(e.mark.line + 1) +
                           ": malformed YAML: " + e.msg);
    }
    if (!root->IsMap()) return Status::Error(file_ + ": expected a mapping");
    return CheckDuplicateKeys(*root, "");
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
    read_.insert(full);
    *out = child;
    return Status::Ok();
  }

  // After a loader read what it knows: a key it never read is a typo (a
  // misspelt safety key would silently keep its default) and refused,
  // naming the keys known beside it. Mappings a loader took whole (by
  // iterating them) are not looked into.
  Status CheckNoUnknownKeys(const YAML::Node& root) const {
    return CheckKnown(root, "");
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

  // Number within [lower, upper] (the documented range of a setting).
  Status InRange(const YAML::Node& parent, const std::string& parent_key,
                 const std::string& key, double lower, double upper,
                 double* out) const {
    KCRIG_RETURN_IF_ERROR(Number(parent, parent_key, key, out));
    if (!(*out >= lower && *out <= upper)) {
      return Error(
          parent[key], Join(parent_key, key),
          "must be within [" + Format(lower) + ", " + Format(upper) + "]");
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
                 const std::string& key, Eigen::Vector3d* out) const {
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

  static std::string Format(double value) {
    char text[32];
    std::snprintf(text, sizeof(text), "%g", value);
    return text;
  }

  // yaml-cpp keeps both entries of a repeated key and reads the first: a
  // second "ramp_down_time" further down would be silently ignored.
  Status CheckDuplicateKeys(const YAML::Node& node,
                            const std::string& path) const {
    if (node.IsSequence()) {
      for (size_t i = 0; i < node.size(); ++i) {
        KCRIG_RETURN_IF_ERROR(
            CheckDuplicateKeys(node[i], path + "[" + std::to_string(i) + "]"));
      }
    }
    if (!node.IsMap()) return Status::Ok();
    std::vector<std::pair<std::string, int>> seen;
    for (auto it = node.begin(); it != node.end(); ++it) {
      const std::string key = it->first.IsScalar() ? it->first.Scalar() : "?";
      const int line = it->first.Mark().line + 1;
      for (const auto& [other, other_line] : seen) {
        if (other == key) {
          return Error(it->first, Join(path, key),
                       "duplicate key (first at line " +
                           std::to_string(other_line) + ")");
        }
      }
      seen.emplace_back(key, line);
      KCRIG_RETURN_IF_ERROR(CheckDuplicateKeys(it->second, Join(path, key)));
    }
    return Status::Ok();
  }

  Status CheckKnown(const YAML::Node& node, const std::string& path) const {
    for (auto it = node.begin(); it != node.end(); ++it) {
      const std::string key = it->first.IsScalar() ? it->first.Scalar() : "?";
      const std::string full = Join(path, key);
      if (read_.count(full) == 0 || key.find('.') != std::string::npos) {
        return Error(it->first, full,
                     "unknown key (known here: " + KnownBeside(path) + ")");
      }
      if (it->second.IsMap() && ReadBelow(full)) {
        KCRIG_RETURN_IF_ERROR(CheckKnown(it->second, full));
      }
    }
    return Status::Ok();
  }

  // Whether a key below `path` was read one by one.
  bool ReadBelow(const std::string& path) const {
    const auto next = read_.lower_bound(path + ".");
    return next != read_.end() && next->rfind(path + ".", 0) == 0;
  }

  // The keys read directly under `path`, comma-separated.
  std::string KnownBeside(const std::string& path) const {
    const std::string prefix = path.empty() ? "" : path + ".";
    std::string known;
    for (const std::string& key : read_) {
      if (key.rfind(prefix, 0) != 0) continue;
      const std::string rest = key.substr(prefix.size());
      if (rest.find('.') != std::string::npos) continue;
      known += (known.empty() ? "" : ", ") + rest;
    }
    return known;
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
  mutable std::set<std::string> read_;  // keys read, "section.key"
};

}  // namespace kcrig

#endif  // KCRIG_BASE_YAML_READER_H_
