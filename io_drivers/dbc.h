// The DBC file format (Vector's CAN database, as cantools, canmatrix and
// every CAN tool read it), and the signal codec that it drives.
//
// Supported: VERSION, NS_, BS_, BU_, BO_ with SG_ (Intel and Motorola byte
// order, signed and unsigned, factor, offset, [min|max], unit, receivers),
// classic CAN frames (DLC <= 8) with 11- or 29-bit ids. Statements that
// only annotate (CM_, BA_DEF_, BA_, VAL_, VAL_TABLE_, BO_TX_BU_, ...) are
// read over. Multiplexed signals, IEEE float signals (SIG_VALTYPE_) and CAN
// FD frames are refused with an error rather than decoded wrongly.
//
// One codec: the kcrig driver, the emulator's CAN node, the bus logger and
// the offline log reader all encode and decode through EncodeSignal and
// DecodeSignal with the layouts computed here.
#ifndef KCRIG_IO_DRIVERS_DBC_H_
#define KCRIG_IO_DRIVERS_DBC_H_

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "base/status.h"

namespace kcrig {

struct DbcSignal {
  std::string name;
  int start_bit = 0;          // as written: Intel LSB, Motorola MSB (sawtooth)
  int length = 0;             // [bits], 1..64
  bool little_endian = true;  // @1 Intel, @0 Motorola
  bool is_signed = false;     // - two's complement, + unsigned
  double factor = 1, offset = 0;
  // The physical range [minimum|maximum]; [0|0] in a DBC means none, and
  // then the raw range bounds the value.
  double minimum = 0, maximum = 0;
  std::string unit;
  std::vector<std::string> receivers;

  // Computed by the parser: the signal is bits [shift, shift + length) of
  // the frame's first eight bytes read as one 64-bit integer, little-endian
  // for Intel signals and big-endian for Motorola ones.
  int shift = 0;
  std::uint64_t mask = 0;
  // The physical range the codec clamps to: [minimum|maximum] intersected
  // with what the raw bits can hold; and the raw range.
  double lowest = 0, highest = 0;
  double raw_min = 0, raw_max = 0;
};

struct DbcMessage {
  std::uint32_t id = 0;  // without the extended flag
  bool extended = false;
  std::string name;
  int dlc = 0;
  std::string sender;
  std::vector<DbcSignal> signals;

  const DbcSignal* FindSignal(std::string_view name) const;
};

struct Dbc {
  std::string version;
  std::vector<std::string> nodes;
  std::vector<DbcMessage> messages;

  const DbcMessage* FindMessage(std::string_view name) const;
  const DbcMessage* FindMessage(std::uint32_t id, bool extended) const;
};

// Parses DBC text; `source` names it in errors ("config/kc_rig.dbc:12: ...").
Status ParseDbc(std::string_view text, const std::string& source, Dbc* dbc);
Status LoadDbc(const std::string& path, Dbc* dbc);

// The physical value of a signal in a frame's data (at least the message's
// DLC bytes; shorter frames are the caller's to refuse). A value outside
// [lowest, highest] is clamped and *out_of_range set (never cleared).
double DecodeSignal(const DbcSignal& signal, const std::uint8_t* data,
                    bool* out_of_range);

// Writes a physical value into a frame's data (8 bytes), leaving the other
// bits alone. Rounds to the nearest raw step; a value outside [lowest,
// highest] is clamped (NaN: written as the value nearest zero),
// never wrapped, and *out_of_range set (never cleared).
void EncodeSignal(const DbcSignal& signal, double value, std::uint8_t* data,
                  bool* out_of_range);

}  // namespace kcrig

#endif  // KCRIG_IO_DRIVERS_DBC_H_
