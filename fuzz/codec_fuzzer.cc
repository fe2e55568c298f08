// The rig protocol's codec on any frame and any value: received frames go
// through the same classification, shape check and sample assembly as
// CanRig; encoded values decode within the DBC range, clamped and flagged
// when outside it, and within half a step when inside.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "io_drivers/kc_rig_protocol.h"

namespace {

struct Fixture {
  kcrig::Dbc dbc;
  kcrig::KcRigProtocol protocol;
  Fixture() {
    if (!kcrig::LoadDbc(KCRIG_DBC_FILE, &dbc).ok() ||
        !protocol.Bind(dbc, KCRIG_DBC_FILE).ok()) {
      abort();
    }
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  static Fixture fixture;
  static kcrig::KcSampleAssembler assembler(&fixture.protocol);
  const kcrig::KcRigProtocol& protocol = fixture.protocol;
  // Byte 0: the number of frames (0..8), 11 bytes each (id low, id high +
  // flags, dlc, 8 data bytes); then doubles to encode.
  const std::size_t frames = size > 0 ? data[0] % 9 : 0;
  std::size_t at = 1;
  for (std::size_t k = 0; k < frames && at + 11 <= size; ++k, at += 11) {
    kcrig::CanFrame frame;
    frame.id = (data[at] | (data[at + 1] & 0x07) << 8);
    frame.remote = data[at + 1] & 0x08;
    frame.extended = data[at + 1] & 0x10;
    frame.error = data[at + 1] & 0x20;
    frame.dlc = data[at + 2] % 9;
    std::memcpy(frame.data, data + at + 3, 8);
    const kcrig::KcFrame kind = protocol.Classify(frame);
    if (kind == kcrig::KcFrame::kCount || !protocol.WellFormed(frame, kind)) {
      continue;
    }
    bool flagged = false;
    kcrig::RigMeasurement sample;
    switch (kind) {
      case kcrig::KcFrame::kCommand:
        protocol.DecodeCommand(frame, &flagged);
        break;
      case kcrig::KcFrame::kSetup:
        protocol.DecodeSetup(frame, &flagged);
        break;
      case kcrig::KcFrame::kSession:
        protocol.DecodeSession(frame);
        break;
      case kcrig::KcFrame::kHeartbeat:
        protocol.DecodeHeartbeat(frame);
        break;
      default:
        if (assembler.Add(frame, kind, &sample) &&
            !(sample.force.allFinite() && sample.y.allFinite())) {
          abort();
        }
    }
  }
  // Values: whatever doubles the rest of the input holds.
  for (; at + 8 <= size; at += 8) {
    double value;
    std::memcpy(&value, data + at, 8);
    for (const kcrig::DbcMessage& message : fixture.dbc.messages) {
      for (const kcrig::DbcSignal& signal : message.signals) {
        std::uint8_t bytes[8] = {};
        bool flagged = false;
        kcrig::EncodeSignal(signal, value, bytes, &flagged);
        bool ignored = false;
        const double back = kcrig::DecodeSignal(signal, bytes, &ignored);
        if (!(back >= signal.lowest && back <= signal.highest)) abort();
        const bool inside = value >= signal.lowest && value <= signal.highest;
        if (inside == flagged) abort();
        if (inside && std::abs(back - value) >
                          0.5 * std::abs(signal.factor) * (1 + 1e-9) +
                              1e-12 * std::abs(value)) {
          abort();
        }
      }
    }
  }
  return 0;
}
