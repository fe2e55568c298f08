// The SocketCAN transport: kcrig as the CAN controller of the rig, behind
// the loop's RigInterface, speaking config/kc_rig.dbc (io_drivers/
// kc_rig_protocol.h).
//
// One master: Configure refuses a rig whose heartbeat names an owner;
// Activate claims it for a random session (KC_Session) and sees the rig
// name that session; every KC_Command carries it; Deactivate and OnError
// release it. Read() returns kForeign (the loop trips) once the rig names
// another owner, or once another controller sends a frame the rig may have
// obeyed: a KC_Command or KC_Session with this session, or a KC_Setup (the
// kernel never hands a socket its own frames, so every controller frame
// received is someone else's). Other sessions' frames, which the rig
// refuses, are counted (foreign_frames).
//
// Read() drains the socket without blocking (at most kMaxFramesPerRead
// frames, so a flood cannot hold the cycle) and returns the newest complete
// sample. Write() sends KC_Command (and KC_Setup every 100 cycles) without
// blocking. Frames that are not the protocol's shape (wrong length, remote,
// extended id), unknown ids within the rig's id pages, repeated (stale) and
// out-of-sequence samples are counted and dropped. Error frames are opted
// in: bus-off, error-passive and tx timeout are faults (Read returns
// kFault, the loop trips); a transmit queue that stays full (ENOBUFS) for
// can.tx_timeout is a tx timeout too. Other error frames are counted.
//
// Receive filters pass the 256-id pages of the rig's messages (0x200 and
// 0x300 for kc_rig.dbc), so unknown ids there are seen and counted, and
// the controller's own three ids; the rest of the bus never reaches the
// process.
//
// Every frame sent or taken in goes to the bus log (candump -l format) when
// one is given, in the order the controller handled it; it is kept (renamed
// from .partial) when an activated rig is deactivated, and removed when the
// rig never got activated.
#ifndef KCRIG_IO_DRIVERS_CAN_RIG_H_
#define KCRIG_IO_DRIVERS_CAN_RIG_H_

#include <memory>
#include <string>

#include "io_drivers/can_frame.h"
#include "io_drivers/kc_rig_protocol.h"
#include "io_drivers/socket_can.h"
#include "io_drivers/transport_config.h"
#include "rt_core/runtime/rig_interface.h"

namespace kcrig {

// can:IFACE -> IFACE
Status ParseCanUri(const std::string& uri, std::string* interface);

// What an error frame means for the rig: "CAN bus-off", "CAN tx timeout",
// "CAN error-passive", or nullptr for errors that are only counted
// (error-warning, protocol violations, lost arbitration, no ACK, ...).
const char* CanErrorFault(const CanFrame& error_frame);

struct CanRigOptions {
  std::string interface;  // vcan0, can0
  CanSettings settings;   // rig.yaml can:
  double period = 1e-3;   // the loop's [s], sent in KC_Setup
  // Receives every frame (hil/: can.log); none when null.
  std::unique_ptr<CanFrameSink> bus_log;
};

class CanRig : public RigInterface {
 public:
  explicit CanRig(CanRigOptions options);
  ~CanRig() override;

  Status Configure() override;
  Status Activate() override;
  Status Deactivate() override;
  void OnError() override;
  IoResult Read(RigMeasurement* measurement) override;
  IoResult Write(const RigCommand& command) override;
  std::string Describe() const override;
  std::string CountersJson() const override;
  // The bus log's (CanRigOptions::bus_log).
  const std::atomic<bool>* record_write_failed() const override {
    return options_.bus_log ? options_.bus_log->write_failed() : nullptr;
  }
  std::string RecordWriteFailure() const override {
    return options_.bus_log ? options_.bus_log->WriteFailure() : "";
  }

  static constexpr int kMaxFramesPerRead = 64;

 private:
  // Handles one received frame (the cycle's and the lifecycle's path).
  void Take(const TimedCanFrame& frame);
  void TakeForeign(const CanFrame& frame, KcFrame kind);
  void DrainSocket(int max_frames);
  bool SendFrame(const CanFrame& frame);
  bool SendCommand(const KcCommand& command);
  bool SendSession(bool claim, bool release, bool reset_fault);
  // KC_Setup for the current acting height, phase and safety state.
  bool SendSetup(std::uint8_t phase, std::uint8_t safety);
  Status ClaimedElsewhere() const;
  // What the signs of a second master say, or "" without any.
  std::string ForeignMasterText() const;
  void SetFault(const char* what);
  // Keeps the bus log of an activated rig, drops that of one never
  // activated.
  Status FinishBusLog();
  // Lifecycle: sends `command` every 5 ms for up to `timeout` until `done`.
  template <typename Done>
  bool Exchange(KcCommand command, double timeout, Done done);

  CanRigOptions options_;
  KcRigProtocol protocol_;
  KcSampleAssembler assembler_{&protocol_};
  CanSocket socket_;
  double z_a_ = 0;
  const std::uint8_t session_;              // 1..kMaxCanSession
  int sent_phase_ = -1, sent_safety_ = -1;  // in the last KC_Setup
  bool activated_ = false;  // the bus log is kept only for an activated rig

  RigMeasurement latest_;
  bool have_new_sample_ = false;
  bool have_heartbeat_ = false;
  KcHeartbeat heartbeat_;
  std::uint16_t fault_code_ = 0;

  const char* fault_ = nullptr;    // the transport fault, once seen
  bool fault_came_first_ = false;  // before any sign of a second master
  bool fault_reported_ = false;
  bool claim_sent_ = false;  // from the claim until the release
  bool claimed_ = false;     // the rig named this session its owner
  // A second master, once seen: another owner in the heartbeat, or the id
  // of another controller's frame.
  int foreign_owner_ = -1;
  int foreign_frame_id_ = -1;
  bool foreign_reported_ = false;
  std::int64_t queue_full_since_us_ = -1;

  // Counters (CountersJson).
  std::int64_t frames_received_ = 0, frames_sent_ = 0;
  std::int64_t malformed_ = 0, unknown_id_ = 0;
  std::int64_t error_frames_ = 0, queue_full_ = 0, send_errors_ = 0;
  std::int64_t clamped_commands_ = 0, heartbeats_ = 0, receive_errors_ = 0;
  std::int64_t foreign_frames_ = 0, refusing_heartbeats_ = 0;
};

}  // namespace kcrig

#endif  // KCRIG_IO_DRIVERS_CAN_RIG_H_
