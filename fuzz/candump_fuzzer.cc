// The candump log line reader on any text: an error, or a frame that the
// writer formats into a line that reads back as the same frame.
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>

#include "records/internal/candump_log.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  std::string_view text(reinterpret_cast<const char*>(data), size);
  while (!text.empty()) {
    const std::size_t end = text.find('\n');
    const std::string_view line = text.substr(0, end);
    text = end == std::string_view::npos ? "" : text.substr(end + 1);
    kcrig::CandumpRecord record;
    if (!kcrig::ParseCandumpLine(line, "fuzz.log:1", &record).ok()) continue;
    char formatted[kcrig::kCandumpLineMax];
    const std::size_t n =
        kcrig::FormatCandumpLine(record.frame, record.interface, formatted);
    if (n == 0 || n >= kcrig::kCandumpLineMax || formatted[n - 1] != '\n') {
      abort();
    }
    kcrig::CandumpRecord again;
    if (!kcrig::ParseCandumpLine(std::string_view(formatted, n - 1),
                                 "fuzz.log:1", &again)
             .ok()) {
      abort();
    }
    const kcrig::CanFrame &a = record.frame.frame, &b = again.frame.frame;
    if (a.id != b.id || a.extended != b.extended || a.remote != b.remote ||
        a.error != b.error || a.dlc != b.dlc ||
        std::memcmp(a.data, b.data, 8) != 0 ||
        record.frame.time_us != again.frame.time_us ||
        record.interface != again.interface) {
      abort();
    }
  }
  return 0;
}
