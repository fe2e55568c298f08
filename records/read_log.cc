#include "records/read_log.h"

#include "records/mat_run_log.h"

namespace kcrig {

bool IsCanBusLog(const std::string& path) {
  return path.size() >= 4 && path.compare(path.size() - 4, 4, ".log") == 0;
}

Status ReadLog(const std::string& path, const CanLogDecoderOptions& can,
               RunLog* log) {
  if (IsMatRunLog(path)) return ReadMatRunLog(path, log);
  if (!IsCanBusLog(path)) return ReadRunLog(path, log);
  if (can.dbc_file.empty()) {
    return Status::Error(path +
                         ": a CAN bus log needs the protocol's DBC "
                         "(rig.yaml can.dbc) to be decoded");
  }
  return DecodeCanLog(path, can, log);
}

}  // namespace kcrig
