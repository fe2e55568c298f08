// Offline decoding of a CAN run's bus log (candump -l format, kcrig's own
// can.log or a capture of the same bus) into the run log the estimator
// reads, through the same DBC codec and sample assembly as the live
// transport. One row per controller cycle (a KC_Command of the session
// that claimed the rig first, or of the first command's in a capture
// from mid-run, inside the loop: the last KC_Setup's Phase
// is not idle), time = cycle x the KC_Setup period; the row holds the
// newest sample taken in before that command (fresh when it is new), as the
// controller logged it in run.csv. Cycles the controller skipped (gaps in
// the command Sequence) get rows without a fresh sample, as in run.csv.
#ifndef KCRIG_RECORDS_CAN_LOG_DECODER_H_
#define KCRIG_RECORDS_CAN_LOG_DECODER_H_

#include <string>

#include "records/run_log.h"

namespace kcrig {

struct CanLogDecoderOptions {
  std::string dbc_file;  // the protocol (rig.yaml can.dbc)
  // Measurement sigmas for the run log's metadata [m], [rad] (the sensors
  // are not described on the bus; experiment.yaml).
  double sigma_position = 0, sigma_angle = 0;
};

struct CanLogCounts {
  std::int64_t frames = 0, commands = 0, samples = 0, malformed = 0,
               unknown = 0, error_frames = 0;
  std::int64_t foreign = 0;  // KC_Command of another session
};

// Errors name the file and line (a malformed line), or say what the log
// lacks (no KC_Setup before the first loop command, fewer than two rows)
// or that it is of another protocol version.
Status DecodeCanLog(const std::string& path,
                    const CanLogDecoderOptions& options, RunLog* log,
                    CanLogCounts* counts = nullptr);

}  // namespace kcrig

#endif  // KCRIG_RECORDS_CAN_LOG_DECODER_H_
