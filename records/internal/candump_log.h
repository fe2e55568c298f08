// The raw CAN log in can-utils' `candump -l` format, one frame per line:
//
//   (1436509052.249713) vcan0 044#2A366C2A
//
// time stamp (seconds.microseconds), interface, then the frame as can-utils
// writes it: 3 hex digits for an 11-bit id, 8 for a 29-bit id or an error
// frame (CAN_ERR_FLAG 0x20000000 set), '#', the data bytes in hex, or 'R'
// (and the DLC) for a remote frame. canplayer replays such files and
// python-can reads them. Classic CAN only: CAN FD lines ("##") are refused.
#ifndef KCRIG_RECORDS_INTERNAL_CANDUMP_LOG_H_
#define KCRIG_RECORDS_INTERNAL_CANDUMP_LOG_H_

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "base/status.h"
#include "io_drivers/can_frame.h"

namespace kcrig {

// Room for the longest line FormatCandumpLine writes (with an interface name
// of up to 15 characters, IFNAMSIZ - 1).
inline constexpr std::size_t kCandumpLineMax = 64;

// Writes one line, '\n' included, into `out` (kCandumpLineMax bytes);
// returns its length. No allocation (the bus logger calls it per frame).
std::size_t FormatCandumpLine(const TimedCanFrame& frame,
                              std::string_view interface, char* out);

struct CandumpRecord {
  TimedCanFrame frame;
  std::string interface;
};

// Parses one line (without its '\n'). `where` prefixes errors
// ("can.log:12").
Status ParseCandumpLine(std::string_view line, const std::string& where,
                        CandumpRecord* record);

// Reads a whole log; errors name file and line. Blank lines are skipped.
Status ReadCandumpLog(const std::string& path,
                      std::vector<CandumpRecord>* records);

}  // namespace kcrig

#endif  // KCRIG_RECORDS_INTERNAL_CANDUMP_LOG_H_
