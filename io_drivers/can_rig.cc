#include "io_drivers/can_rig.h"

#include <linux/can/error.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <random>
#include <thread>

#include "nlohmann/json.hpp"

namespace kcrig {
namespace {

// The rig's ids and their 256-id page: the receive filters.
std::vector<CanFilter> RigPages(const KcRigProtocol& protocol) {
  std::vector<CanFilter> filters;
  for (KcFrame kind :
       {KcFrame::kPositionXY, KcFrame::kPositionZToe, KcFrame::kAngles,
        KcFrame::kForce, KcFrame::kHeartbeat}) {
    const CanFilter page{protocol.id(kind) & 0x700u, 0x700u};
    bool known = false;
    for (const CanFilter& f : filters) known |= f.id == page.id;
    if (!known) filters.push_back(page);
  }
  // Another controller's frames: the kernel never loops our own back.
  for (KcFrame kind : {KcFrame::kCommand, KcFrame::kSetup, KcFrame::kSession}) {
    filters.push_back({protocol.id(kind), 0x7FFu});
  }
  return filters;
}

std::uint8_t NewSession() {
  std::random_device device;
  return static_cast<std::uint8_t>(1 + device() % kMaxCanSession);
}

std::string Hex(unsigned id) {
  char text[16];
  std::snprintf(text, sizeof(text), "0x%03x", id);
  return text;
}

bool IsSampleFrame(KcFrame kind) {
  return kind == KcFrame::kPositionXY || kind == KcFrame::kPositionZToe ||
         kind == KcFrame::kAngles || kind == KcFrame::kForce;
}

}  // namespace

Status ParseCanUri(const std::string& uri, std::string* interface) {
  if (uri.rfind("can:", 0) != 0 || uri.size() == 4 || uri.size() > 4 + 15 ||
      uri.find_first_of(" /:", 4) != std::string::npos) {
    return Status::Error("--rig " + uri +
                         ": expected can:IFACE (e.g. can:can0, can:vcan0)");
  }
  *interface = uri.substr(4);
  return Status::Ok();
}

const char* CanErrorFault(const CanFrame& frame) {
  if (!frame.error) return nullptr;
  if (frame.id & CAN_ERR_BUSOFF) return "CAN bus-off";
  if (frame.id & CAN_ERR_TX_TIMEOUT) return "CAN tx timeout";
  if ((frame.id & CAN_ERR_CRTL) && frame.dlc >= 2 &&
      (frame.data[1] & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE))) {
    return "CAN error-passive";
  }
  return nullptr;
}

CanRig::CanRig(CanRigOptions options)
    : options_(std::move(options)), session_(NewSession()) {}

// A rig that was never activated ran no experiment: its bus log goes.
CanRig::~CanRig() {
  if (options_.bus_log) options_.bus_log->Discard();
}

std::string CanRig::Describe() const { return "can:" + options_.interface; }

Status CanRig::Configure() {
  Dbc dbc;
  Status status = LoadDbc(options_.settings.dbc_file, &dbc);
  if (!status.ok()) return status;
  status = protocol_.Bind(dbc, options_.settings.dbc_file);
  if (!status.ok()) return status;
  CanSocketOptions socket_options;
  socket_options.interface = options_.interface;
  socket_options.filters = RigPages(protocol_);
  socket_options.error_frames = true;
  status = socket_.Open(socket_options);
  if (!status.ok()) return status;
  if (options_.bus_log) {
    status = options_.bus_log->Start(options_.interface);
    if (!status.ok()) return status;
  }
  // The rig must be there and speak this protocol before anything starts.
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::microseconds(static_cast<long>(
                            options_.settings.connect_timeout * 1e6));
  while (!have_heartbeat_ && std::chrono::steady_clock::now() < deadline) {
    if (socket_.WaitReadable(0.01)) DrainSocket(1000);
  }
  if (!have_heartbeat_) {
    return Status::Error(Describe() + ": no heartbeat (KC_Heartbeat, id " +
                         std::to_string(protocol_.id(KcFrame::kHeartbeat)) +
                         ") from the rig within " +
                         std::to_string(options_.settings.connect_timeout) +
                         " s (is the rig, or kcrig emulate --can " +
                         options_.interface + ", on the bus?)");
  }
  if (heartbeat_.protocol != kKcRigProtocolVersion) {
    return Status::Error(Describe() + ": the rig speaks protocol " +
                         std::to_string(heartbeat_.protocol) + ", expected " +
                         std::to_string(kKcRigProtocolVersion));
  }
  if (heartbeat_.owner != 0) return ClaimedElsewhere();
  return Status::Ok();
}

Status CanRig::ClaimedElsewhere() const {
  std::string why;
  if (heartbeat_.owner != 0 && heartbeat_.owner != session_) {
    why = "another master (session " + std::to_string(heartbeat_.owner) +
          ") is in control; stop it, or wait until the rig's command "
          "watchdog releases it";
  } else if (foreign_frame_id_ >= 0) {
    why = "another controller sends " + Hex(foreign_frame_id_) +
          " with this controller's session or none; stop it";
  } else {
    why = "the rig did not grant this controller's claim (session " +
          std::to_string(session_) + ") within 1 s";
  }
  return Status::Error(Describe() +
                       ": the rig refuses this controller: " + why);
}

void CanRig::SetFault(const char* what) {
  if (fault_ != nullptr) return;
  fault_ = what;
  fault_came_first_ = foreign_owner_ < 0 && foreign_frame_id_ < 0;
}

void CanRig::Take(const TimedCanFrame& timed) {
  if (options_.bus_log) options_.bus_log->Push(timed);
  ++frames_received_;
  const CanFrame& frame = timed.frame;
  if (frame.error) {
    ++error_frames_;
    const char* fault = CanErrorFault(frame);
    if (fault != nullptr) SetFault(fault);
    return;
  }
  const KcFrame kind = protocol_.Classify(frame);
  if (kind == KcFrame::kCount) {
    if (frame.extended || frame.remote) {
      ++malformed_;
    } else {
      ++unknown_id_;
    }
    return;
  }
  if (!protocol_.WellFormed(frame, kind)) {
    ++malformed_;
    return;
  }
  if (kind == KcFrame::kHeartbeat) {
    heartbeat_ = protocol_.DecodeHeartbeat(frame);
    have_heartbeat_ = true;
    fault_code_ = heartbeat_.fault_code;
    ++heartbeats_;
    if (heartbeat_.refusing) ++refusing_heartbeats_;
    if (claimed_ && heartbeat_.owner != session_ && foreign_owner_ < 0) {
      foreign_owner_ = heartbeat_.owner;
    }
    return;
  }
  if (!IsSampleFrame(kind)) {
    TakeForeign(frame, kind);
    return;
  }
  if (assembler_.Add(frame, kind, &latest_)) have_new_sample_ = true;
}

// Another controller's frame (the kernel never hands us our own). The rig
// refuses a command or session request of another session, so it is only
// counted; one that carries this session, or a KC_Setup (which carries
// none), may have been obeyed: a second master.
void CanRig::TakeForeign(const CanFrame& frame, KcFrame kind) {
  ++foreign_frames_;
  bool clamped = false;
  const int session = kind == KcFrame::kCommand
                          ? protocol_.DecodeCommand(frame, &clamped).session
                      : kind == KcFrame::kSession
                          ? protocol_.DecodeSession(frame).session
                          : -1;
  if (claim_sent_ && (session < 0 || session == session_) &&
      foreign_frame_id_ < 0) {
    foreign_frame_id_ = static_cast<int>(frame.id);
  }
}

void CanRig::DrainSocket(int max_frames) {
  TimedCanFrame timed;
  int error = 0;
  for (int k = 0; k < max_frames && socket_.Receive(&timed, &error); ++k) {
    Take(timed);
  }
  if (error != 0) ++receive_errors_;
}

bool CanRig::SendFrame(const CanFrame& frame) {
  int error = 0;
  const CanSocket::SendResult result = socket_.Send(frame, &error);
  const std::int64_t now = WallClockMicros();
  if (result == CanSocket::SendResult::kSent) {
    ++frames_sent_;
    queue_full_since_us_ = -1;
    if (options_.bus_log) options_.bus_log->Push(TimedCanFrame{now, frame});
    return true;
  }
  if (result == CanSocket::SendResult::kQueueFull) {
    ++queue_full_;
    if (queue_full_since_us_ < 0) queue_full_since_us_ = now;
    if (now - queue_full_since_us_ >=
        static_cast<std::int64_t>(options_.settings.tx_timeout * 1e6)) {
      SetFault("CAN tx timeout (transmit queue full, ENOBUFS)");
    }
  } else {
    ++send_errors_;
    SetFault("CAN interface down");
  }
  return false;
}

bool CanRig::SendCommand(const KcCommand& command) {
  bool clamped = false;
  const CanFrame frame = protocol_.EncodeCommand(command, &clamped);
  if (clamped) ++clamped_commands_;
  return SendFrame(frame);
}

bool CanRig::SendSession(bool claim, bool release, bool reset_fault) {
  return SendFrame(
      protocol_.EncodeSession({session_, claim, release, reset_fault}));
}

bool CanRig::SendSetup(std::uint8_t phase, std::uint8_t safety) {
  bool clamped = false;
  const KcSetup setup{z_a_, options_.period, kKcRigProtocolVersion, phase,
                      safety};
  sent_phase_ = phase;
  sent_safety_ = safety;
  return SendFrame(protocol_.EncodeSetup(setup, &clamped));
}

template <typename Done>
bool CanRig::Exchange(KcCommand command, double timeout, Done done) {
  const auto deadline =
      std::chrono::steady_clock::now() +
      std::chrono::microseconds(static_cast<long>(timeout * 1e6));
  for (;;) {
    SendCommand(command);
    ++command.sequence;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    DrainSocket(1000);
    if (done()) return true;
    if (std::chrono::steady_clock::now() >= deadline) return false;
  }
}

Status CanRig::Activate() {
  SendSetup(0, 0);
  // Claim the rig and reset a latched fault at zero force, see the rig name
  // this session, then enable and see the rig report itself enabled
  // without fault.
  SendSession(true, false, true);
  claim_sent_ = true;
  KcCommand command;
  command.session = session_;
  have_heartbeat_ = false;
  const bool owned = Exchange(command, 1.0, [this] {
    return have_heartbeat_ && heartbeat_.owner == session_;
  });
  if (!owned || foreign_frame_id_ >= 0) return ClaimedElsewhere();
  claimed_ = true;
  command.enable = true;
  have_new_sample_ = false;
  const bool enabled = Exchange(command, 0.2, [this] {
    return have_new_sample_ && (latest_.status & kRigEnabled) &&
           !(latest_.status & kRigFault);
  });
  if (fault_ != nullptr) return Status::Error(Describe() + ": " + fault_);
  if (foreign_owner_ >= 0 || foreign_frame_id_ >= 0) return ClaimedElsewhere();
  if (!enabled) {
    return Status::Error(Describe() +
                         ": the rig did not report itself enabled (status " +
                         std::to_string(latest_.status) + ", fault code " +
                         std::to_string(fault_code_) + ")");
  }
  // The sample that showed the rig enabled is the loop's first (the bus
  // log's decoder counts it the same way).
  activated_ = true;
  return Status::Ok();
}

Status CanRig::Deactivate() {
  SendSetup(0, 0);    // outside the loop again: lifecycle commands follow
  KcCommand command;  // zero force, disabled
  command.session = session_;
  const bool disabled = Exchange(command, 0.05, [this] {
    return have_new_sample_ && !(latest_.status & kRigEnabled);
  });
  SendSession(false, true, false);
  claim_sent_ = claimed_ = false;
  // Frames still under way belong in the log.
  std::this_thread::sleep_for(std::chrono::milliseconds(10));
  DrainSocket(10000);
  const Status closed = FinishBusLog();
  if (!closed.ok()) return closed;
  if (!disabled) {
    return Status::Error(Describe() +
                         ": the rig did not confirm it is disabled");
  }
  return Status::Ok();
}

Status CanRig::FinishBusLog() {
  if (!options_.bus_log) return Status::Ok();
  if (activated_) return options_.bus_log->Close();
  options_.bus_log->Discard();
  return Status::Ok();
}

void CanRig::OnError() {
  SendSetup(0, 0);
  KcCommand command;
  command.session = session_;
  for (int k = 0; k < 3; ++k) SendCommand(command);
  if (claim_sent_) SendSession(false, true, false);
  claim_sent_ = claimed_ = false;
  FinishBusLog();
}

IoResult CanRig::Read(RigMeasurement* measurement) {
  DrainSocket(kMaxFramesPerRead);
  if (fault_ != nullptr && !fault_reported_) {
    fault_reported_ = true;
    return IoResult::kFault;
  }
  if ((foreign_owner_ >= 0 || foreign_frame_id_ >= 0) && !foreign_reported_) {
    foreign_reported_ = true;  // once: the ramp-down still logs samples
    return IoResult::kForeign;
  }
  if (!have_new_sample_) return IoResult::kStale;
  have_new_sample_ = false;
  *measurement = latest_;
  measurement->fault_code = fault_code_;
  return IoResult::kFresh;
}

IoResult CanRig::Write(const RigCommand& command) {
  z_a_ = command.z_a;
  bool ok = true;
  // The phase and safety state hold from the next command on: a change goes
  // out first.
  if (command.sequence % kSetupEveryCycles == 0 ||
      command.phase != sent_phase_ || command.safety != sent_safety_) {
    ok &= SendSetup(command.phase, command.safety);
  }
  KcCommand frame;
  frame.force = command.force;
  frame.sequence = static_cast<std::uint8_t>(command.sequence);
  frame.enable = command.enable;
  frame.session = session_;
  ok &= SendCommand(frame);
  return ok ? IoResult::kFresh : IoResult::kError;
}

std::string CanRig::CountersJson() const {
  nlohmann::ordered_json j;
  j["frames_received"] = frames_received_;
  j["frames_sent"] = frames_sent_;
  j["heartbeats"] = heartbeats_;
  j["malformed_frames"] = malformed_;
  j["unknown_id_frames"] = unknown_id_;
  j["stale_frames"] = assembler_.stale();
  j["out_of_sequence_frames"] = assembler_.out_of_sequence();
  j["incomplete_samples"] = assembler_.incomplete();
  j["out_of_range_samples"] = assembler_.out_of_range();
  j["clamped_commands"] = clamped_commands_;
  j["session"] = session_;
  j["foreign_frames"] = foreign_frames_;
  j["refusing_heartbeats"] = refusing_heartbeats_;
  j["error_frames"] = error_frames_;
  j["transmit_queue_full"] = queue_full_;
  j["send_errors"] = send_errors_;
  j["receive_errors"] = receive_errors_;
  const CanFrameSink* log = options_.bus_log.get();
  j["bus_log_frames"] = log != nullptr ? log->written() : 0;
  j["bus_log_dropped"] = log != nullptr ? log->dropped() : 0;
  // The first of a transport fault and a second master is what tripped the
  // run; one that followed (a rig releasing a claim the ramp-down could not
  // renew) is named after it.
  std::string first = fault_ != nullptr ? fault_ : "";
  std::string then = ForeignMasterText();
  if (first.empty() || (!then.empty() && !fault_came_first_)) {
    std::swap(first, then);
  }
  if (!then.empty()) first += "; then " + then;
  if (!first.empty()) j["fault"] = first;
  return j.dump();
}

std::string CanRig::ForeignMasterText() const {
  if (foreign_owner_ > 0) {
    return "the rig obeys another master: it reports session " +
           std::to_string(foreign_owner_) +
           " in control, not this controller's " + std::to_string(session_);
  }
  if (foreign_owner_ == 0) {
    return "the rig released this controller's claim (its command watchdog, "
           "or a restart): it obeys no master now";
  }
  if (foreign_frame_id_ < 0) return "";
  return "the rig may obey another master: another controller sends " +
         Hex(foreign_frame_id_) +
         (foreign_frame_id_ == static_cast<int>(protocol_.id(KcFrame::kSetup))
              ? " (which carries no session)"
              : " with this controller's session " + std::to_string(session_)) +
         " on the bus";
}

}  // namespace kcrig
