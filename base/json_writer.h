// The writers' side of the JSON files the offline tools and the console
// write: JSON has no NaN or infinity, so a number that is not finite (an
// interval not computed, a share not seen) is written as null, one rule for
// every file; the readers (base/json_reader.h) take null for "not there".
#ifndef KCRIG_BASE_JSON_WRITER_H_
#define KCRIG_BASE_JSON_WRITER_H_

#include <cmath>

#include "nlohmann/json.hpp"

namespace kcrig {

template <typename JsonType = nlohmann::ordered_json>
JsonType FiniteOrNull(double value) {
  return std::isfinite(value) ? JsonType(value) : JsonType(nullptr);
}

}  // namespace kcrig

#endif  // KCRIG_BASE_JSON_WRITER_H_
