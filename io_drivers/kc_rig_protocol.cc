#include "io_drivers/kc_rig_protocol.h"

#include <cmath>

namespace kcrig {
namespace {

struct SignalName {
  KcFrame message;
  const char* name;
};

constexpr const char* kMessageNames[] = {
    "KC_Command",      "KC_Setup",  "KC_Session", "KC_PositionXY",
    "KC_PositionZToe", "KC_Angles", "KC_Force",   "KC_Heartbeat",
};

// In the order of KcRigProtocol::Signal.
constexpr SignalName kSignalNames[] = {
    {KcFrame::kCommand, "Fx_Set"},
    {KcFrame::kCommand, "Fy_Set"},
    {KcFrame::kCommand, "Fz_Set"},
    {KcFrame::kCommand, "Sequence"},
    {KcFrame::kCommand, "Enable"},
    {KcFrame::kCommand, "Session"},
    {KcFrame::kSetup, "ActingHeight"},
    {KcFrame::kSetup, "CyclePeriod"},
    {KcFrame::kSetup, "Protocol"},
    {KcFrame::kSetup, "Phase"},
    {KcFrame::kSetup, "Safety"},
    {KcFrame::kSession, "Session"},
    {KcFrame::kSession, "Claim"},
    {KcFrame::kSession, "Release"},
    {KcFrame::kSession, "ResetFault"},
    {KcFrame::kPositionXY, "X"},
    {KcFrame::kPositionXY, "Y"},
    {KcFrame::kPositionXY, "Counter"},
    {KcFrame::kPositionXY, "Status"},
    {KcFrame::kPositionZToe, "Z"},
    {KcFrame::kPositionZToe, "Toe"},
    {KcFrame::kPositionZToe, "Counter"},
    {KcFrame::kPositionZToe, "Status"},
    {KcFrame::kAngles, "Camber"},
    {KcFrame::kAngles, "Caster"},
    {KcFrame::kAngles, "Counter"},
    {KcFrame::kAngles, "Status"},
    {KcFrame::kForce, "Fx"},
    {KcFrame::kForce, "Fy"},
    {KcFrame::kForce, "Fz"},
    {KcFrame::kForce, "Counter"},
    {KcFrame::kForce, "Status"},
    {KcFrame::kHeartbeat, "Status"},
    {KcFrame::kHeartbeat, "FaultCode"},
    {KcFrame::kHeartbeat, "Protocol"},
    {KcFrame::kHeartbeat, "SampleCounter"},
    {KcFrame::kHeartbeat, "Owner"},
    {KcFrame::kHeartbeat, "Refusing"},
};

// Integer signals (counters, bits, codes) decode exactly.
unsigned DecodeInteger(const DbcSignal& signal, const std::uint8_t* data) {
  bool ignored = false;
  return static_cast<unsigned>(
      std::lround(DecodeSignal(signal, data, &ignored)));
}

CanFrame EmptyFrame(const DbcMessage& message) {
  CanFrame frame;
  frame.id = message.id;
  frame.extended = message.extended;
  frame.dlc = static_cast<std::uint8_t>(message.dlc);
  return frame;
}

}  // namespace

Status KcRigProtocol::Bind(const Dbc& dbc, const std::string& source) {
  static_assert(sizeof(kSignalNames) / sizeof(kSignalNames[0]) == kSignalCount);
  for (int k = 0; k < Index(KcFrame::kCount); ++k) {
    const DbcMessage* message = dbc.FindMessage(kMessageNames[k]);
    if (message == nullptr) {
      return Status::Error(source + ": no message " + kMessageNames[k] +
                           " (not the kcrig rig protocol?)");
    }
    if (message->dlc != 8 || message->extended) {
      return Status::Error(source + ": message " + kMessageNames[k] +
                           " must be a standard-id frame of 8 bytes");
    }
    messages_[k] = *message;
  }
  for (int k = 0; k < kSignalCount; ++k) {
    const DbcMessage& message = messages_[Index(kSignalNames[k].message)];
    const DbcSignal* signal = message.FindSignal(kSignalNames[k].name);
    if (signal == nullptr) {
      return Status::Error(source + ": message " + message.name +
                           " has no signal " + kSignalNames[k].name);
    }
    signals_[k] = *signal;
  }
  for (int a = 0; a < Index(KcFrame::kCount); ++a) {
    for (int b = a + 1; b < Index(KcFrame::kCount); ++b) {
      if (messages_[a].id == messages_[b].id) {
        return Status::Error(source + ": " + messages_[a].name + " and " +
                             messages_[b].name + " share an id");
      }
    }
  }
  return Status::Ok();
}

KcFrame KcRigProtocol::Classify(const CanFrame& frame) const {
  if (frame.error || frame.extended) return KcFrame::kCount;
  for (int k = 0; k < Index(KcFrame::kCount); ++k) {
    if (messages_[k].id == frame.id) return static_cast<KcFrame>(k);
  }
  return KcFrame::kCount;
}

bool KcRigProtocol::WellFormed(const CanFrame& frame, KcFrame kind) const {
  return !frame.error && !frame.extended && !frame.remote &&
         frame.dlc >= messages_[Index(kind)].dlc;
}

CanFrame KcRigProtocol::EncodeCommand(const KcCommand& command,
                                      bool* out_of_range) const {
  CanFrame frame = EmptyFrame(messages_[Index(KcFrame::kCommand)]);
  for (int k = 0; k < 3; ++k) {
    EncodeSignal(signals_[kFxSet + k], command.force(k), frame.data,
                 out_of_range);
  }
  EncodeSignal(signals_[kSequence], command.sequence, frame.data, out_of_range);
  EncodeSignal(signals_[kEnable], command.enable ? 1 : 0, frame.data,
               out_of_range);
  EncodeSignal(signals_[kCommandSession], command.session, frame.data,
               out_of_range);
  return frame;
}

CanFrame KcRigProtocol::EncodeSetup(const KcSetup& setup,
                                    bool* out_of_range) const {
  CanFrame frame = EmptyFrame(messages_[Index(KcFrame::kSetup)]);
  EncodeSignal(signals_[kActingHeight], setup.z_a, frame.data, out_of_range);
  EncodeSignal(signals_[kCyclePeriod], setup.period, frame.data, out_of_range);
  EncodeSignal(signals_[kSetupProtocol], setup.protocol, frame.data,
               out_of_range);
  EncodeSignal(signals_[kPhase], setup.phase, frame.data, out_of_range);
  EncodeSignal(signals_[kSafety], setup.safety, frame.data, out_of_range);
  return frame;
}

CanFrame KcRigProtocol::EncodeSession(const KcSession& session) const {
  CanFrame frame = EmptyFrame(messages_[Index(KcFrame::kSession)]);
  bool ignored = false;
  EncodeSignal(signals_[kSessionSession], session.session, frame.data,
               &ignored);
  EncodeSignal(signals_[kClaim], session.claim ? 1 : 0, frame.data, &ignored);
  EncodeSignal(signals_[kRelease], session.release ? 1 : 0, frame.data,
               &ignored);
  EncodeSignal(signals_[kResetFault], session.reset_fault ? 1 : 0, frame.data,
               &ignored);
  return frame;
}

void KcRigProtocol::EncodeSample(const RigMeasurement& sample, CanFrame* frames,
                                 bool* out_of_range) const {
  const double counter = sample.sample & 0xFFu;
  const double status = sample.status & 0xFFu;
  const KcFrame kinds[kSampleFrames] = {KcFrame::kPositionXY,
                                        KcFrame::kPositionZToe,
                                        KcFrame::kAngles, KcFrame::kForce};
  const Signal first[kSampleFrames] = {kX, kZ, kCamber, kFx};
  for (int f = 0; f < kSampleFrames; ++f) {
    frames[f] = EmptyFrame(messages_[Index(kinds[f])]);
    const int channels = kinds[f] == KcFrame::kForce ? 3 : 2;
    for (int c = 0; c < channels; ++c) {
      const double value =
          kinds[f] == KcFrame::kForce ? sample.force(c) : sample.y(2 * f + c);
      EncodeSignal(signals_[first[f] + c], value, frames[f].data, out_of_range);
    }
    EncodeSignal(signals_[first[f] + channels], counter, frames[f].data,
                 out_of_range);
    EncodeSignal(signals_[first[f] + channels + 1], status, frames[f].data,
                 out_of_range);
  }
}

CanFrame KcRigProtocol::EncodeHeartbeat(const KcHeartbeat& heartbeat) const {
  CanFrame frame = EmptyFrame(messages_[Index(KcFrame::kHeartbeat)]);
  bool ignored = false;
  EncodeSignal(signals_[kHbStatus], heartbeat.status & 0xFFu, frame.data,
               &ignored);
  EncodeSignal(signals_[kHbFault], heartbeat.fault_code & 0xFFu, frame.data,
               &ignored);
  EncodeSignal(signals_[kHbProtocol], heartbeat.protocol, frame.data, &ignored);
  EncodeSignal(signals_[kHbSample], heartbeat.sample, frame.data, &ignored);
  EncodeSignal(signals_[kHbOwner], heartbeat.owner, frame.data, &ignored);
  EncodeSignal(signals_[kHbRefusing], heartbeat.refusing ? 1 : 0, frame.data,
               &ignored);
  return frame;
}

KcCommand KcRigProtocol::DecodeCommand(const CanFrame& frame,
                                       bool* out_of_range) const {
  KcCommand command;
  for (int k = 0; k < 3; ++k) {
    command.force(k) =
        DecodeSignal(signals_[kFxSet + k], frame.data, out_of_range);
  }
  command.sequence =
      static_cast<std::uint8_t>(DecodeInteger(signals_[kSequence], frame.data));
  command.enable = DecodeInteger(signals_[kEnable], frame.data) != 0;
  command.session = static_cast<std::uint8_t>(
      DecodeInteger(signals_[kCommandSession], frame.data));
  return command;
}

KcSetup KcRigProtocol::DecodeSetup(const CanFrame& frame,
                                   bool* out_of_range) const {
  KcSetup setup;
  setup.z_a = DecodeSignal(signals_[kActingHeight], frame.data, out_of_range);
  setup.period = DecodeSignal(signals_[kCyclePeriod], frame.data, out_of_range);
  setup.protocol =
      static_cast<int>(DecodeInteger(signals_[kSetupProtocol], frame.data));
  setup.phase =
      static_cast<std::uint8_t>(DecodeInteger(signals_[kPhase], frame.data));
  setup.safety =
      static_cast<std::uint8_t>(DecodeInteger(signals_[kSafety], frame.data));
  return setup;
}

KcSession KcRigProtocol::DecodeSession(const CanFrame& frame) const {
  KcSession session;
  session.session = static_cast<std::uint8_t>(
      DecodeInteger(signals_[kSessionSession], frame.data));
  session.claim = DecodeInteger(signals_[kClaim], frame.data) != 0;
  session.release = DecodeInteger(signals_[kRelease], frame.data) != 0;
  session.reset_fault = DecodeInteger(signals_[kResetFault], frame.data) != 0;
  return session;
}

KcHeartbeat KcRigProtocol::DecodeHeartbeat(const CanFrame& frame) const {
  KcHeartbeat heartbeat;
  heartbeat.status = static_cast<std::uint16_t>(
      DecodeInteger(signals_[kHbStatus], frame.data));
  heartbeat.fault_code =
      static_cast<std::uint16_t>(DecodeInteger(signals_[kHbFault], frame.data));
  heartbeat.protocol =
      static_cast<int>(DecodeInteger(signals_[kHbProtocol], frame.data));
  bool ignored = false;
  heartbeat.sample = static_cast<std::uint32_t>(
      DecodeSignal(signals_[kHbSample], frame.data, &ignored));
  heartbeat.owner =
      static_cast<std::uint8_t>(DecodeInteger(signals_[kHbOwner], frame.data));
  heartbeat.refusing = DecodeInteger(signals_[kHbRefusing], frame.data) != 0;
  return heartbeat;
}

void KcRigProtocol::DecodeSampleFrame(const CanFrame& frame, KcFrame kind,
                                      RigMeasurement* sample,
                                      std::uint8_t* counter,
                                      std::uint16_t* status,
                                      bool* out_of_range) const {
  Signal first = kX;
  int y_index = 0;
  switch (kind) {
    case KcFrame::kPositionXY:
      first = kX, y_index = 0;
      break;
    case KcFrame::kPositionZToe:
      first = kZ, y_index = 2;
      break;
    case KcFrame::kAngles:
      first = kCamber, y_index = 4;
      break;
    default:
      first = kFx;
      break;
  }
  const int channels = kind == KcFrame::kForce ? 3 : 2;
  for (int c = 0; c < channels; ++c) {
    const double value =
        DecodeSignal(signals_[first + c], frame.data, out_of_range);
    if (kind == KcFrame::kForce) {
      sample->force(c) = value;
    } else {
      sample->y(y_index + c) = value;
    }
  }
  *counter = static_cast<std::uint8_t>(
      DecodeInteger(signals_[first + channels], frame.data));
  *status = static_cast<std::uint16_t>(
      DecodeInteger(signals_[first + channels + 1], frame.data));
}

bool KcSampleAssembler::Add(const CanFrame& frame, KcFrame kind,
                            RigMeasurement* sample) {
  RigMeasurement parts = pending_;
  std::uint8_t counter = 0;
  std::uint16_t status = 0;
  bool out_of_range = false;
  protocol_->DecodeSampleFrame(frame, kind, &parts, &counter, &status,
                               &out_of_range);
  const unsigned bit =
      1u << (static_cast<int>(kind) - static_cast<int>(KcFrame::kPositionXY));
  if (have_pending_ && counter == pending_counter_) {
    if (pending_parts_ & bit) {
      ++stale_;  // the same frame twice
      return false;
    }
  } else {
    if (have_delivered_ && counter == last_counter_) {
      ++stale_;
      return false;
    }
    const bool have_reference = have_pending_ || have_delivered_;
    const std::uint8_t newest =
        have_pending_ ? pending_counter_ : last_counter_;
    const std::uint8_t ahead = static_cast<std::uint8_t>(counter - newest);
    if (have_reference && ahead >= 128) {
      ++out_of_sequence_;
      return false;
    }
    if (have_pending_) ++incomplete_;
    // A new sample: channels left from the abandoned one are overwritten
    // by this sample's own frames before it can complete.
    have_pending_ = true;
    pending_counter_ = counter;
    pending_parts_ = 0;
  }
  if (out_of_range) ++out_of_range_;
  pending_ = parts;
  pending_.status = status;
  pending_parts_ |= bit;
  if (pending_parts_ != (1u << kSampleFrames) - 1) return false;
  sample_number_ =
      have_delivered_
          ? sample_number_ + static_cast<std::uint8_t>(counter - last_counter_)
          : counter;
  have_delivered_ = true;
  last_counter_ = counter;
  have_pending_ = false;
  pending_.sample = sample_number_;
  *sample = pending_;
  return true;
}

}  // namespace kcrig
