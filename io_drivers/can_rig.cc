#include "io_drivers/can_rig.h"

#include <linux/can/error.h>

#include <chrono>
#include <cstring>
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
  return filters;
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

CanRig::CanRig(CanRigOptions options) : options_(std::move(options)) {}

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
  return Status::Ok();
}

void CanRig::SetFault(const char* what) {
  if (fault_ == nullptr) fault_ = what;
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
    return;
  }
  if (!IsSampleFrame(kind)) {
    ++unexpected_;  // a controller's frame from someone else
    return;
  }
  if (assembler_.Add(frame, kind, &latest_)) have_new_sample_ = true;
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
  bool clamped = false;
  KcSetup setup{z_a_, options_.period, kKcRigProtocolVersion};
  SendFrame(protocol_.EncodeSetup(setup, &clamped));
  // Reset a latched fault at zero force, then enable and see the rig
  // report itself enabled without fault.
  KcCommand command;
  command.reset_fault = true;
  Exchange(command, 0.02, [] { return false; });
  command.reset_fault = false;
  command.enable = true;
  have_new_sample_ = false;
  const bool enabled = Exchange(command, 0.2, [this] {
    return have_new_sample_ && (latest_.status & kRigEnabled) &&
           !(latest_.status & kRigFault);
  });
  if (fault_ != nullptr) return Status::Error(Describe() + ": " + fault_);
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
  KcCommand command;  // zero force, disabled
  const bool disabled = Exchange(command, 0.05, [this] {
    return have_new_sample_ && !(latest_.status & kRigEnabled);
  });
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
  KcCommand command;
  for (int k = 0; k < 3; ++k) SendCommand(command);
  FinishBusLog();
}

IoResult CanRig::Read(RigMeasurement* measurement) {
  DrainSocket(kMaxFramesPerRead);
  if (fault_ != nullptr && !fault_reported_) {
    fault_reported_ = true;
    return IoResult::kFault;
  }
  if (!have_new_sample_) return IoResult::kStale;
  have_new_sample_ = false;
  *measurement = latest_;
  measurement->fault_code = fault_code_;
  return IoResult::kFresh;
}

IoResult CanRig::Write(const RigCommand& command) {
  z_a_ = command.z_a;
  KcCommand frame;
  frame.force = command.force;
  frame.sequence = static_cast<std::uint8_t>(command.sequence);
  frame.enable = command.enable;
  frame.phase = command.phase;
  frame.safety = command.safety;
  bool ok = SendCommand(frame);
  if (command.sequence % kSetupEveryCycles == 0) {
    bool clamped = false;
    const KcSetup setup{command.z_a, options_.period, kKcRigProtocolVersion};
    ok &= SendFrame(protocol_.EncodeSetup(setup, &clamped));
  }
  return ok ? IoResult::kFresh : IoResult::kError;
}

std::string CanRig::CountersJson() const {
  nlohmann::ordered_json j;
  j["frames_received"] = frames_received_;
  j["frames_sent"] = frames_sent_;
  j["heartbeats"] = heartbeats_;
  j["malformed_frames"] = malformed_;
  j["unknown_id_frames"] = unknown_id_;
  j["unexpected_frames"] = unexpected_;
  j["stale_frames"] = assembler_.stale();
  j["out_of_sequence_frames"] = assembler_.out_of_sequence();
  j["incomplete_samples"] = assembler_.incomplete();
  j["out_of_range_samples"] = assembler_.out_of_range();
  j["clamped_commands"] = clamped_commands_;
  j["error_frames"] = error_frames_;
  j["transmit_queue_full"] = queue_full_;
  j["send_errors"] = send_errors_;
  j["receive_errors"] = receive_errors_;
  const CanFrameSink* log = options_.bus_log.get();
  j["bus_log_frames"] = log != nullptr ? log->written() : 0;
  j["bus_log_dropped"] = log != nullptr ? log->dropped() : 0;
  if (fault_ != nullptr) j["fault"] = fault_;
  return j.dump();
}

}  // namespace kcrig
