#include "emulator/can_front_end.h"

#include "io_drivers/kc_rig_protocol.h"
#include "io_drivers/socket_can.h"

namespace kcrig {
namespace {

// The rig's CAN node between frames: the acting height of the last
// KC_Setup, the last sample sent, the heartbeat's schedule.
class CanNode {
 public:
  CanNode(RigEmulator* rig, const KcRigProtocol& protocol, CanSocket* socket,
          CanNodeCounters* counters)
      : rig_(rig),
        protocol_(protocol),
        socket_(socket),
        counters_(counters),
        last_sample_(rig->TakeSample()),
        refused_at_heartbeat_(rig->ownership().refused()) {}

  // A frame of the controller's page: a setup, a session request or a
  // command, which the owner's is answered with a sample.
  void OnFrame(const CanFrame& frame, double now) {
    const KcFrame kind = protocol_.Classify(frame);
    if (kind != KcFrame::kCommand && kind != KcFrame::kSetup &&
        kind != KcFrame::kSession) {
      return;
    }
    if (!protocol_.WellFormed(frame, kind)) {
      ++counters_->malformed;
      return;
    }
    bool clamped = false;
    rig_->AdvanceTo(now);
    if (kind == KcFrame::kSetup) {
      z_a_ = protocol_.DecodeSetup(frame, &clamped).z_a;
      return;
    }
    RigRequest request;
    request.command.z_a = z_a_;
    request.ownership.has_session = true;
    if (kind == KcFrame::kSession) {
      const KcSession session = protocol_.DecodeSession(frame);
      request.ownership.session = session.session;
      request.ownership.claim = session.claim;
      request.ownership.release = session.release;
      request.reset_fault = session.reset_fault;
      if (!rig_->Request(request)) ++counters_->refused;
      return;
    }
    const KcCommand decoded = protocol_.DecodeCommand(frame, &clamped);
    request.command.force = decoded.force;
    request.command.enable = decoded.enable;
    request.command.sequence = decoded.sequence;
    request.ownership.session = decoded.session;
    request.ownership.enable = decoded.enable;
    // A refused command gets no sample: the owner's samples stay its own.
    if (!rig_->Request(request)) {
      ++counters_->refused;
      return;
    }
    ++counters_->commands;
    last_sample_ = rig_->TakeSample();
    CanFrame frames[kSampleFrames];
    protocol_.EncodeSample(last_sample_, frames, &clamped);
    for (const CanFrame& f : frames) Send(f);
    ++counters_->samples_sent;
  }

  // The heartbeat, every kHeartbeatPeriod and at once on a status change.
  void Heartbeat(double now) {
    const std::uint16_t rig_status = rig_->status();
    if (now < next_heartbeat_ && rig_status == last_status_) return;
    KcHeartbeat heartbeat;
    heartbeat.status = rig_status;
    heartbeat.fault_code = rig_->fault();
    heartbeat.protocol = kKcRigProtocolVersion;
    heartbeat.sample = last_sample_.sample;
    heartbeat.owner = static_cast<std::uint8_t>(rig_->ownership().owner());
    heartbeat.refusing = rig_->ownership().refused() != refused_at_heartbeat_;
    refused_at_heartbeat_ = rig_->ownership().refused();
    Send(protocol_.EncodeHeartbeat(heartbeat));
    ++counters_->heartbeats;
    last_status_ = rig_status;
    next_heartbeat_ = now + kHeartbeatPeriod;
  }

 private:
  void Send(const CanFrame& frame) {
    int error = 0;
    if (socket_->Send(frame, &error) != CanSocket::SendResult::kSent) {
      ++counters_->send_failures;
    }
  }

  RigEmulator* rig_;
  const KcRigProtocol& protocol_;
  CanSocket* socket_;
  CanNodeCounters* counters_;
  RigMeasurement last_sample_;
  double z_a_ = 0;
  double next_heartbeat_ = 0;
  std::uint16_t last_status_ = 0xFFFF;
  std::uint16_t refused_at_heartbeat_;
};

}  // namespace

Status ServeCan(RigEmulator* rig, const Clock& clock,
                const std::string& dbc_file, const std::string& interface,
                const std::atomic<int>& stop,
                const std::function<void()>& on_ready,
                CanNodeCounters* counters) {
  Dbc dbc;
  KCRIG_RETURN_IF_ERROR(LoadDbc(dbc_file, &dbc));
  KcRigProtocol protocol;
  KCRIG_RETURN_IF_ERROR(protocol.Bind(dbc, dbc_file));
  CanSocket socket;
  CanSocketOptions options;
  options.interface = interface;
  // The controller's page (KC_Command, KC_Setup).
  options.filters = {{protocol.id(KcFrame::kCommand) & 0x700u, 0x700u}};
  options.error_frames = false;
  KCRIG_RETURN_IF_ERROR(socket.Open(options));
  KCRIG_RETURN_IF_ERROR(rig->Start(clock.Seconds()));
  CanNode node(rig, protocol, &socket, counters);
  on_ready();
  while (stop.load() == 0) {
    socket.WaitReadable(1e-3);
    const double now = clock.Seconds();
    rig->AdvanceTo(now);
    TimedCanFrame timed;
    int error = 0;
    while (socket.Receive(&timed, &error)) {
      node.OnFrame(timed.frame, clock.Seconds());
    }
    node.Heartbeat(now);
  }
  return Status::Ok();
}

}  // namespace kcrig
