// The K&C rig's CAN protocol, bound to the messages and signals of
// config/kc_rig.dbc by name (the DBC is the only place that knows bit
// positions, scales and ranges). Shared by the controller's transport
// (CanRig), the emulator's CAN node, and the offline decoder of candump
// logs, so the three cannot disagree.
//
// One master per rig: the controller claims the rig for its session with
// KC_Session and gives it back the same way; the rig obeys only frames
// that carry its owner's session and names the owner in its heartbeat.
// Per controller cycle: KC_Command (set-points, sequence = cycle mod 256,
// enable, session) controller -> rig; the rig answers with one sample in
// four frames (KC_PositionXY, KC_PositionZToe, KC_Angles, KC_Force) that
// share a Counter (the rig's sample counter mod 256) and carry the rig's
// status. KC_Setup (acting height, cycle period, run phase, safety state)
// goes out at activation, every 100 cycles and before the command of a
// cycle whose phase or safety state changed; KC_Heartbeat (status, fault
// code, 32-bit sample counter, owner) at 10 Hz and on every status
// change.
#ifndef KCRIG_IO_DRIVERS_KC_RIG_PROTOCOL_H_
#define KCRIG_IO_DRIVERS_KC_RIG_PROTOCOL_H_

#include <cstdint>

#include "io_drivers/can_frame.h"
#include "io_drivers/dbc.h"
#include "rt_core/model/rig_signals.h"

namespace kcrig {

// 3: one master (KC_Session, KC_Command's Session, the heartbeat's Owner);
// Phase and Safety moved from KC_Command to KC_Setup.
inline constexpr int kKcRigProtocolVersion = 3;
inline constexpr int kMaxCanSession = 127;  // sessions are 1..127
inline constexpr int kSetupEveryCycles = 100;
inline constexpr double kHeartbeatPeriod = 0.1;  // [s]

enum class KcFrame {
  kCommand,
  kSetup,
  kSession,
  kPositionXY,
  kPositionZToe,
  kAngles,
  kForce,
  kHeartbeat,
  kCount,
};
inline constexpr int kSampleFrames = 4;  // kPositionXY .. kForce

// What a KC_Command frame carries.
struct KcCommand {
  Vec3<double> force = Vec3<double>::Zero();  // [N]
  std::uint8_t sequence = 0;
  bool enable = false;
  std::uint8_t session = 0;
};

struct KcSetup {
  double z_a = 0;     // [m]
  double period = 0;  // [s]
  int protocol = 0;
  std::uint8_t phase = 0;   // 0 idle, else 1 + RunPhase
  std::uint8_t safety = 0;  // SafetyState
};

// What a KC_Session frame carries.
struct KcSession {
  std::uint8_t session = 0;
  bool claim = false;
  bool release = false;
  bool reset_fault = false;
};

struct KcHeartbeat {
  std::uint16_t status = 0;  // RigStatusBit
  std::uint16_t fault_code = 0;
  int protocol = 0;
  std::uint32_t sample = 0;
  std::uint8_t owner = 0;  // 0: unclaimed
  bool refusing = false;   // refused another session since the last one
};

class KcRigProtocol {
 public:
  // Finds every message and signal the protocol needs in `dbc` and checks
  // their DLC; errors name the missing piece.
  Status Bind(const Dbc& dbc, const std::string& source);

  // The frame's role, by id; kCount for ids that are not the protocol's.
  KcFrame Classify(const CanFrame& frame) const;
  std::uint32_t id(KcFrame kind) const { return messages_[Index(kind)].id; }
  int dlc(KcFrame kind) const { return messages_[Index(kind)].dlc; }

  // Encoders set *out_of_range when a value was clamped to the DBC's
  // range (never cleared). No allocation.
  CanFrame EncodeCommand(const KcCommand& command, bool* out_of_range) const;
  CanFrame EncodeSetup(const KcSetup& setup, bool* out_of_range) const;
  CanFrame EncodeSession(const KcSession& session) const;
  // The four frames of one sample, Counter = sample mod 256.
  void EncodeSample(const RigMeasurement& sample, CanFrame* frames,
                    bool* out_of_range) const;
  CanFrame EncodeHeartbeat(const KcHeartbeat& heartbeat) const;

  // Decoders expect a frame that Classify() gave that kind and that carries
  // at least the message's DLC (the caller counts others as malformed).
  KcCommand DecodeCommand(const CanFrame& frame, bool* out_of_range) const;
  KcSetup DecodeSetup(const CanFrame& frame, bool* out_of_range) const;
  KcSession DecodeSession(const CanFrame& frame) const;
  KcHeartbeat DecodeHeartbeat(const CanFrame& frame) const;
  // One sample frame into *sample (its channels only); returns its Counter
  // and status.
  void DecodeSampleFrame(const CanFrame& frame, KcFrame kind,
                         RigMeasurement* sample, std::uint8_t* counter,
                         std::uint16_t* status, bool* out_of_range) const;

  // Whether a received frame has the shape of its message (standard id,
  // not remote, not an error frame, DLC at least the message's).
  bool WellFormed(const CanFrame& frame, KcFrame kind) const;

 private:
  static int Index(KcFrame kind) { return static_cast<int>(kind); }
  enum Signal {
    kFxSet,
    kFySet,
    kFzSet,
    kSequence,
    kEnable,
    kCommandSession,
    kActingHeight,
    kCyclePeriod,
    kSetupProtocol,
    kPhase,
    kSafety,
    kSessionSession,
    kClaim,
    kRelease,
    kResetFault,
    kX,
    kY,
    kXYCounter,
    kXYStatus,
    kZ,
    kToe,
    kZCounter,
    kZStatus,
    kCamber,
    kCaster,
    kAnglesCounter,
    kAnglesStatus,
    kFx,
    kFy,
    kFz,
    kForceCounter,
    kForceStatus,
    kHbStatus,
    kHbFault,
    kHbProtocol,
    kHbSample,
    kHbOwner,
    kHbRefusing,
    kSignalCount,
  };
  DbcMessage messages_[static_cast<int>(KcFrame::kCount)];
  DbcSignal signals_[kSignalCount];
};

// Puts the frames of rig samples back together: a sample is delivered when
// its four frames with one Counter have arrived. Frames of an older sample
// (Counter behind the newest seen) are out of sequence, a repeat of the
// delivered sample is stale; both are counted and dropped. A sample whose
// frames stop coming is abandoned when a newer one starts. The 32-bit
// sample number is the Counter unwrapped.
class KcSampleAssembler {
 public:
  explicit KcSampleAssembler(const KcRigProtocol* protocol)
      : protocol_(protocol) {}

  // Feeds one well-formed sample frame; true when it completed a sample,
  // which is then in *sample (all channels, status, unwrapped number).
  bool Add(const CanFrame& frame, KcFrame kind, RigMeasurement* sample);

  std::int64_t out_of_sequence() const { return out_of_sequence_; }
  std::int64_t stale() const { return stale_; }
  std::int64_t incomplete() const { return incomplete_; }
  std::int64_t out_of_range() const { return out_of_range_; }

 private:
  const KcRigProtocol* protocol_;
  RigMeasurement pending_;
  std::uint8_t pending_counter_ = 0;
  unsigned pending_parts_ = 0;  // bit per frame kind
  bool have_pending_ = false;
  std::uint8_t last_counter_ = 0;  // of the last delivered sample
  bool have_delivered_ = false;
  std::uint32_t sample_number_ = 0;
  std::int64_t out_of_sequence_ = 0, stale_ = 0, incomplete_ = 0,
               out_of_range_ = 0;
};

}  // namespace kcrig

#endif  // KCRIG_IO_DRIVERS_KC_RIG_PROTOCOL_H_
