// The DBC parser on any text: an error or a database whose every signal the
// codec handles within its declared range.
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "io_drivers/dbc.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  kcrig::Dbc dbc;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  if (!kcrig::ParseDbc(text, "fuzz.dbc", &dbc).ok()) return 0;
  for (const kcrig::DbcMessage& message : dbc.messages) {
    for (const kcrig::DbcSignal& signal : message.signals) {
      for (std::uint8_t fill : {0x00, 0x55, 0xFF}) {
        std::uint8_t bytes[8];
        for (auto& b : bytes) b = fill;
        bool flagged = false;
        const double value = kcrig::DecodeSignal(signal, bytes, &flagged);
        if (!(value >= signal.lowest && value <= signal.highest)) abort();
        kcrig::EncodeSignal(signal, signal.highest, bytes, &flagged);
        kcrig::EncodeSignal(signal, signal.lowest, bytes, &flagged);
        const double low = kcrig::DecodeSignal(signal, bytes, &flagged);
        if (!(low >= signal.lowest && low <= signal.highest)) abort();
      }
    }
  }
  return 0;
}
