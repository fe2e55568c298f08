#include "emulator/can_front_end.h"

#include "io_drivers/kc_rig_protocol.h"
#include "io_drivers/socket_can.h"

namespace kcrig {

Status ServeCan(RigEmulator* rig, const Clock& clock,
                const std::string& dbc_file, const std::string& interface,
                const std::atomic<int>& stop,
                const std::function<void()>& on_ready,
                CanNodeCounters* counters) {
  Dbc dbc;
  Status status = LoadDbc(dbc_file, &dbc);
  if (!status.ok()) return status;
  KcRigProtocol protocol;
  status = protocol.Bind(dbc, dbc_file);
  if (!status.ok()) return status;
  CanSocket socket;
  CanSocketOptions options;
  options.interface = interface;
  // The controller's page (KC_Command, KC_Setup).
  options.filters = {{protocol.id(KcFrame::kCommand) & 0x700u, 0x700u}};
  options.error_frames = false;
  status = socket.Open(options);
  if (!status.ok()) return status;
  status = rig->Start(clock.Seconds());
  if (!status.ok()) return status;

  auto send = [&](const CanFrame& frame) {
    int error = 0;
    if (socket.Send(frame, &error) != CanSocket::SendResult::kSent) {
      ++counters->send_failures;
    }
  };
  RigMeasurement last_sample = rig->TakeSample();
  double z_a = 0;
  double next_heartbeat = 0;
  std::uint16_t last_status = 0xFFFF;
  std::uint16_t refused_at_heartbeat = rig->ownership().refused();
  on_ready();
  while (stop.load() == 0) {
    socket.WaitReadable(1e-3);
    const double now = clock.Seconds();
    rig->AdvanceTo(now);
    TimedCanFrame timed;
    int error = 0;
    while (socket.Receive(&timed, &error)) {
      const CanFrame& frame = timed.frame;
      const KcFrame kind = protocol.Classify(frame);
      if (kind != KcFrame::kCommand && kind != KcFrame::kSetup &&
          kind != KcFrame::kSession) {
        continue;
      }
      if (!protocol.WellFormed(frame, kind)) {
        ++counters->malformed;
        continue;
      }
      bool clamped = false;
      rig->AdvanceTo(clock.Seconds());
      if (kind == KcFrame::kSetup) {
        z_a = protocol.DecodeSetup(frame, &clamped).z_a;
        continue;
      }
      RigRequest request;
      request.command.z_a = z_a;
      request.ownership.has_session = true;
      if (kind == KcFrame::kSession) {
        const KcSession session = protocol.DecodeSession(frame);
        request.ownership.session = session.session;
        request.ownership.claim = session.claim;
        request.ownership.release = session.release;
        request.reset_fault = session.reset_fault;
        if (!rig->Request(request)) ++counters->refused;
        continue;
      }
      const KcCommand decoded = protocol.DecodeCommand(frame, &clamped);
      request.command.force = decoded.force;
      request.command.enable = decoded.enable;
      request.command.sequence = decoded.sequence;
      request.ownership.session = decoded.session;
      request.ownership.enable = decoded.enable;
      // A refused command gets no sample: the owner's samples stay its own.
      if (!rig->Request(request)) {
        ++counters->refused;
        continue;
      }
      ++counters->commands;
      last_sample = rig->TakeSample();
      CanFrame frames[kSampleFrames];
      protocol.EncodeSample(last_sample, frames, &clamped);
      for (const CanFrame& f : frames) send(f);
      ++counters->samples_sent;
    }
    const std::uint16_t rig_status = rig->status();
    if (now >= next_heartbeat || rig_status != last_status) {
      KcHeartbeat heartbeat;
      heartbeat.status = rig_status;
      heartbeat.fault_code = rig->fault();
      heartbeat.protocol = kKcRigProtocolVersion;
      heartbeat.sample = last_sample.sample;
      heartbeat.owner = static_cast<std::uint8_t>(rig->ownership().owner());
      heartbeat.refusing = rig->ownership().refused() != refused_at_heartbeat;
      refused_at_heartbeat = rig->ownership().refused();
      send(protocol.EncodeHeartbeat(heartbeat));
      ++counters->heartbeats;
      last_status = rig_status;
      next_heartbeat = now + kHeartbeatPeriod;
    }
  }
  return Status::Ok();
}

}  // namespace kcrig
