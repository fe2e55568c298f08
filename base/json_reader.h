// Field-by-field reading of the JSON files the offline tools write
// (design.json, campaign.json, diag.json, timing.json), for the readers
// beside their writers: every error names the file and the field, and no
// JSON exception crosses a module boundary.
#ifndef KCRIG_BASE_JSON_READER_H_
#define KCRIG_BASE_JSON_READER_H_

#include <cmath>
#include <fstream>
#include <string>
#include <type_traits>

#include "base/input_file.h"
#include "base/status.h"
#include "nlohmann/json.hpp"

namespace kcrig {

// The whole file as JSON; numbers beyond double's range are errors.
inline Status ReadJsonFile(const std::string& path, nlohmann::json* doc) {
  constexpr std::uintmax_t kMaxJsonBytes = 256u << 20;
  KCRIG_RETURN_IF_ERROR(CheckInputFile(path, kMaxJsonBytes));
  std::ifstream in(path);
  if (!in) return Status::Error(path + ": cannot open");
  try {
    *doc = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    return Status::Error(path + ": not valid JSON (" + e.what() + ")");
  }
  return Status::Ok();
}

// `node[key]` as a T; `where` (file and path so far) leads the error.
template <typename T>
Status ReadField(const nlohmann::json& node, const std::string& key,
                 const std::string& where, T* value) {
  if (!node.is_object() || !node.contains(key)) {
    return Status::Error(where + ": missing field '" + key + "'");
  }
  try {
    *value = node.at(key).get<T>();
  } catch (const nlohmann::json::exception&) {
    return Status::Error(where + "." + key + ": unexpected type (" +
                         node.at(key).type_name() + ")");
  }
  if constexpr (std::is_floating_point_v<T>) {
    if (!std::isfinite(*value)) {
      return Status::Error(where + "." + key + ": not a finite number");
    }
  }
  return Status::Ok();
}

// Runs `read`, which reads `path`: JSON of a shape the field checks did not
// anticipate becomes an error naming the file instead of an exception.
template <typename Read>
Status GuardedRead(const std::string& path, Read&& read) {
  try {
    return read();
  } catch (const nlohmann::json::exception& e) {
    return Status::Error(path + ": unexpected content (" + e.what() + ")");
  }
}

}  // namespace kcrig

#endif  // KCRIG_BASE_JSON_READER_H_
