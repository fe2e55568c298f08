// The run log's sidecar (run.json) as text and back, shared by the CSV log
// and the MAT-file log (which carries the same text in a variable).
#ifndef KCRIG_RECORDS_INTERNAL_RUN_LOG_SIDECAR_H_
#define KCRIG_RECORDS_INTERNAL_RUN_LOG_SIDECAR_H_

#include <cstdint>
#include <string>

#include "base/status.h"
#include "nlohmann/json.hpp"
#include "records/run_log.h"

namespace kcrig {

// The sidecar of `log` for `rows` rows (format "kcrig run log 1").
std::string FormatSidecar(const RunLog& log, std::int64_t rows);

// Reads a sidecar `doc` (named `path` in errors) into `m`, checking it
// against the log it describes: `rows` samples from `first_t` to `last_t`.
Status ParseSidecar(const nlohmann::json& doc, const std::string& path,
                    size_t rows, double first_t, double last_t, RunMetadata* m);

}  // namespace kcrig

#endif  // KCRIG_RECORDS_INTERNAL_RUN_LOG_SIDECAR_H_
