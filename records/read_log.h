// One reader for every log the offline tools take: a run log (run.csv with
// its sidecar, or the same as a MATLAB MAT-file `.mat`) or a CAN bus log (a
// `.log` in candump -l format, decoded with the DBC the caller passes in).
#ifndef KCRIG_RECORDS_READ_LOG_H_
#define KCRIG_RECORDS_READ_LOG_H_

#include <string>

#include "base/status.h"
#include "records/can_log_decoder.h"
#include "records/run_log.h"

namespace kcrig {

// Whether `path` names a CAN bus log (by its `.log` extension).
bool IsCanBusLog(const std::string& path);

// ReadRunLog, ReadMatRunLog for a `.mat`, or DecodeCanLog with `can` for a
// CAN bus log (an error when `can.dbc_file` is empty).
Status ReadLog(const std::string& path, const CanLogDecoderOptions& can,
               RunLog* log);

}  // namespace kcrig

#endif  // KCRIG_RECORDS_READ_LOG_H_
