#include "io_drivers/modbus_rig.h"

#include <modbus/modbus.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>

#include "io_drivers/modbus_registers.h"

namespace kcrig {
namespace {

// The whole reply must arrive within `seconds`: a zero byte timeout makes
// libmodbus keep counting down the response timeout across partial reads
// (a per-byte timeout would restart with every fragment).
void SetTimeout(modbus_t* context, double seconds) {
  const auto micros = static_cast<std::uint32_t>(seconds * 1e6);
  modbus_set_response_timeout(context, micros / 1000000, micros % 1000000);
  modbus_set_byte_timeout(context, 0, 0);
}

// libmodbus uses the response timeout as the TCP connect timeout too.
constexpr double kConnectTimeout = 1.0;  // [s]

std::string Hex(std::uint16_t value) {
  char text[8];
  std::snprintf(text, sizeof(text), "0x%04x", value);
  return text;
}

// A session token no other controller is likely to hold (neither 0 nor
// the hidden owner's value).
std::uint16_t NewSession() {
  std::random_device device;
  std::uint16_t session = 0;
  while (session == 0 || session == kOwnerHidden) {
    session = static_cast<std::uint16_t>(device());
  }
  return session;
}

// What the owner register says to a controller that is not the owner.
std::string OwnerText(std::uint16_t owner) {
  return owner == kOwnerHidden ? "another session (the rig names it only to "
                                 "that session's own connection)"
                               : "session " + Hex(owner);
}

}  // namespace

Status ParseModbusUri(const std::string& uri, ModbusEndpoint* endpoint) {
  const std::string tcp = "modbus-tcp://", rtu = "modbus-rtu://";
  if (uri.rfind(rtu, 0) == 0) {
    endpoint->rtu = true;
    endpoint->device = uri.substr(rtu.size());
    if (endpoint->device.empty()) {
      return Status::Error("--rig " + uri + ": expected modbus-rtu://DEVICE");
    }
    return Status::Ok();
  }
  if (uri.rfind(tcp, 0) != 0) {
    return Status::Error("--rig " + uri +
                         ": expected modbus-tcp://HOST:PORT or "
                         "modbus-rtu://DEVICE");
  }
  endpoint->rtu = false;
  const Status status =
      ParseHostPort(uri.substr(tcp.size()), "modbus-tcp://HOST:PORT", 1,
                    &endpoint->host, &endpoint->port);
  if (!status.ok()) {
    return Status::Error("--rig " + uri + ": " + status.message());
  }
  return Status::Ok();
}

Status CheckRtuWireTime(const ModbusEndpoint& endpoint, const ModbusMap& map,
                        const ModbusSettings& settings, double period) {
  if (!endpoint.rtu) return Status::Ok();
  const int bits_per_character = 1 + settings.data_bits +
                                 (settings.parity == 'N' ? 0 : 1) +
                                 settings.stop_bits;
  auto wire_time = [&](double characters) {
    return characters * bits_per_character / settings.baud;
  };
  // Function 4: request 8 bytes, reply 5 + 2 per register; function 16:
  // request 9 + 2 per register, reply 8; 3.5 characters before each frame.
  const double read = wire_time(8 + 5 + 2 * map.input_count() + 2 * 3.5);
  const double write = wire_time(9 + 2 * map.holding_count() + 8 + 2 * 3.5);
  auto ms = [](double seconds) {
    char text[32];
    std::snprintf(text, sizeof(text), "%.2f ms", seconds * 1e3);
    return std::string(text);
  };
  const std::string where = "--rig modbus-rtu://" + endpoint.device + ": at " +
                            std::to_string(settings.baud) + " baud ";
  if (read + write > period) {
    return Status::Error(where + "one cycle's read and write take " +
                         ms(read + write) +
                         " on the wire, more than "
                         "loop.period (" +
                         ms(period) +
                         "): lengthen loop.period in rig.yaml or raise "
                         "modbus.rtu.baud");
  }
  if (read > settings.response_timeout) {
    return Status::Error(where + "the read's request and reply take " +
                         ms(read) +
                         " on the wire, more than "
                         "modbus.response_timeout (" +
                         ms(settings.response_timeout) + ")");
  }
  return Status::Ok();
}

ModbusRig::ModbusRig(const ModbusEndpoint& endpoint, const ModbusMap& map,
                     const ModbusSettings& settings)
    : endpoint_(endpoint),
      map_(map),
      settings_(settings),
      session_(NewSession()) {}

ModbusRig::~ModbusRig() {
  {
    std::lock_guard<std::mutex> lock(wake_mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (reconnect_thread_.joinable()) reconnect_thread_.join();
  if (context_ != nullptr) {
    modbus_close(context_);
    modbus_free(context_);
  }
}

std::string ModbusRig::Describe() const {
  if (endpoint_.rtu) return "modbus-rtu://" + endpoint_.device;
  return "modbus-tcp://" + endpoint_.host + ":" +
         std::to_string(endpoint_.port);
}

std::string ModbusRig::CountersJson() const {
  char late[96];
  std::snprintf(late, sizeof(late),
                ", \"late_replies\": %lld, \"late_reply_max_ms\": %.3f",
                static_cast<long long>(late_replies_), late_reply_max_s_ * 1e3);
  std::string json = "{\"reconnects\": " + std::to_string(reconnects_.load()) +
                     ", \"session\": " + std::to_string(session_) + late +
                     ", \"refused_writes\": " + std::to_string(refused_writes_);
  if (foreign_) {
    json += ", \"fault\": \"the rig obeys another master: ";
    json += foreign_echo_ours_
                ? "it reports " + OwnerText(foreign_owner_) +
                      " in control, not this controller's " + Hex(session_) +
                      (reconnects_.load() > 0 && foreign_owner_ == kOwnerHidden
                           ? " (after a reconnect: perhaps this controller's "
                             "previous connection, not yet closed at the rig)"
                           : "")
                : "it echoes command sequence " +
                      std::to_string(foreign_echo_) +
                      ", which this controller did not send (a second "
                      "master wrote to the rig, or the rig restarted)";
    json += "\"";
  }
  return json + "}";
}

void ModbusRig::RememberSent(std::uint16_t sequence) {
  sent_[sent_count_ % sent_.size()] = sequence;
  ++sent_count_;
}

bool ModbusRig::ForeignMasterSeen() {
  const std::uint16_t owner = input_[map_.owner];
  const std::uint16_t echo = input_[map_.sequence_echo];
  const auto sent_end =
      sent_.begin() + static_cast<long>(std::min(sent_count_, sent_.size()));
  // Before the first write there is nothing of ours to echo.
  const bool echo_ours =
      sent_count_ == 0 || std::find(sent_.begin(), sent_end, echo) != sent_end;
  // Owner 0: the rig released this controller (its watchdog); it then
  // reports itself disabled, which the loop trips on as a rig fault.
  if ((owner == 0 || owner == session_) && echo_ours) return false;
  foreign_ = true;
  foreign_owner_ = owner;
  foreign_echo_ = echo;
  foreign_echo_ours_ = echo_ours;
  return true;
}

Status ModbusRig::Configure() {
  context_ = endpoint_.rtu
                 ? modbus_new_rtu(endpoint_.device.c_str(), settings_.baud,
                                  settings_.parity, settings_.data_bits,
                                  settings_.stop_bits)
                 : modbus_new_tcp(endpoint_.host.c_str(), endpoint_.port);
  if (context_ == nullptr) {
    return Status::Error(Describe() + ": " + modbus_strerror(errno));
  }
  modbus_set_slave(context_, map_.unit_id);
  // Set-up gets a patient timeout; the cycle's short one comes after.
  SetTimeout(context_, kConnectTimeout);
  if (modbus_connect(context_) == -1) {
    return Status::Error(Describe() + ": cannot connect (" +
                         modbus_strerror(errno) + ")");
  }
  const int count = map_.input_count();
  if (modbus_read_input_registers(context_, 0, count, input_) != count) {
    const int error = errno;
    if (error == ECONNRESET || error == EPIPE || error == ECONNABORTED) {
      return Status::Error(
          Describe() +
          ": the rig closed the connection at once (it serves a bounded "
          "number of clients: too many others connected, or it refuses "
          "this host)");
    }
    if (error == EMBXSBUSY) {
      return Status::Error(Describe() + ": the rig is busy (exception 6)");
    }
    return Status::Error(Describe() + ": reading input registers 0.." +
                         std::to_string(count - 1) + " failed (" +
                         modbus_strerror(error) + ")");
  }
  if (input_[map_.protocol] != kModbusProtocolVersion) {
    return Status::Error(Describe() + ": input register " +
                         std::to_string(map_.protocol) + " (protocol) is " +
                         std::to_string(input_[map_.protocol]) + ", expected " +
                         std::to_string(kModbusProtocolVersion) +
                         " (not a kcrig register map?)");
  }
  if (input_[map_.owner] != 0) return ClaimedElsewhere();
  SetTimeout(context_, settings_.response_timeout);
  connected_ = true;
  reconnect_thread_ = std::thread([this] { ReconnectLoop(); });
  return Status::Ok();
}

Status ModbusRig::WriteControl(std::uint16_t control_word, int attempts) {
  std::memset(holding_, 0, sizeof(holding_));
  holding_[map_.control_word] = control_word;
  holding_[map_.sequence] = ++sequence_;
  holding_[map_.session] = session_;
  RememberSent(sequence_);
  for (int k = 0; k < 3; ++k) {
    PutFloat32(0.0, map_.high_word_first, &holding_[map_.setpoint[k]]);
  }
  PutFloat32(z_a_, map_.high_word_first, &holding_[map_.z_a]);
  const int count = map_.holding_count();
  for (int attempt = 0; attempt < attempts; ++attempt) {
    if (connected_) FlushIfNeeded();
    if (connected_ &&
        modbus_write_registers(context_, 0, count, holding_) == count) {
      return Status::Ok();
    }
    if (connected_ && errno == EMBXSBUSY) return ClaimedElsewhere();
    if (connected_) OnRequestFailed();
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return Status::Error(Describe() + ": writing the control word failed (" +
                       modbus_strerror(errno) + ")");
}

Status ModbusRig::ClaimedElsewhere() {
  // Best effort: the owner and the fault for the message.
  if (modbus_read_input_registers(context_, 0, map_.input_count(), input_) !=
      map_.input_count()) {
    return Status::Error(Describe() +
                         ": the rig refuses this controller's writes (server "
                         "busy) and no longer answers reads");
  }
  const std::uint16_t owner = input_[map_.owner];
  if (owner == 0 || owner == session_) {
    // Not another master: the rig ended this controller's claim itself.
    const std::uint16_t fault = input_[map_.fault_code];
    return Status::Error(
        Describe() + ": the rig refuses this controller: it ended its claim" +
        (fault != kFaultNone ? " after fault " + std::to_string(fault) + " (" +
                                   RigFaultMeaning(fault) + ")"
                             : std::string(" (no fault reported)")));
  }
  return Status::Error(
      Describe() + ": the rig refuses this controller: " + OwnerText(owner) +
      " is in control (another master); stop it, or wait until the rig "
      "releases it (its claim timeout)");
}

Status ModbusRig::Activate() {
  // Claim the rig and reset a latched fault, then enable at zero force,
  // then see the rig report this session in control, enabled and without
  // fault (a rig in local mode or still faulted must not run a test at zero
  // force and call it complete).
  Status status = WriteControl(kControlClaim | kControlResetFault, 5);
  if (!status.ok()) return status;
  status = WriteControl(kControlClaim | kControlEnable, 5);
  if (!status.ok()) return status;
  const int count = map_.input_count();
  for (int attempt = 0; attempt < 20; ++attempt) {
    if (connected_) FlushIfNeeded();
    if (connected_ &&
        modbus_read_input_registers(context_, 0, count, input_) == count) {
      if (input_[map_.owner] != session_) return ClaimedElsewhere();
      refused_at_claim_ = input_[map_.refused_writes];
      const std::uint16_t rig_status = input_[map_.status];
      if ((rig_status & kRigEnabled) && !(rig_status & kRigFault)) {
        // Keep the rig's command watchdog fed until the loop starts.
        return WriteControl(kControlEnable, 5);
      }
    } else if (connected_) {
      OnRequestFailed();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return Status::Error(Describe() +
                       ": the rig did not report itself enabled (status " +
                       std::to_string(input_[map_.status]) + ", fault code " +
                       std::to_string(input_[map_.fault_code]) + ")");
}

Status ModbusRig::Deactivate() { return WriteControl(kControlRelease, 20); }

void ModbusRig::OnError() { WriteControl(kControlRelease, 5); }

void ModbusRig::OnRequestFailed() {
  const int error = errno;
  // Timeouts, exceptions and malformed replies keep the link.
  if (error == ETIMEDOUT || (error > MODBUS_ENOBASE && error <= EMBBADSLAVE)) {
    // The late reply would answer the next request (libmodbus then sees a
    // wrong transaction id): drop whatever arrived before the next request.
    flush_before_request_ = true;
    return;
  }
  // Closing (on a tty it may wait for output to drain) and reconnecting
  // are the reconnect thread's.
  connected_.store(false, std::memory_order_release);
  wake_.notify_one();
}

void ModbusRig::FlushIfNeeded() {
  if (flush_before_request_) {
    modbus_flush(context_);
    flush_before_request_ = false;
  }
}

IoResult ModbusRig::Read(RigMeasurement* measurement) {
  if (!connected_.load(std::memory_order_acquire)) return IoResult::kError;
  FlushIfNeeded();
  const int count = map_.input_count();
  const auto asked = std::chrono::steady_clock::now();
  if (modbus_read_input_registers(context_, 0, count, input_) != count) {
    OnRequestFailed();
    return IoResult::kError;
  }
  const double took =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - asked)
          .count();
  if (took > settings_.response_timeout) {
    ++late_replies_;
    late_reply_max_s_ = std::max(late_reply_max_s_, took);
  }
  refused_writes_ = static_cast<std::uint16_t>(input_[map_.refused_writes] -
                                               refused_at_claim_);
  if (ForeignMasterSeen()) return IoResult::kForeign;
  const bool order = map_.high_word_first;
  const std::uint32_t sample = GetUint32(&input_[map_.sample], order);
  if (have_sample_ && sample == last_sample_) return IoResult::kStale;
  have_sample_ = true;
  last_sample_ = sample;
  measurement->sample = sample;
  measurement->status = input_[map_.status];
  measurement->fault_code = input_[map_.fault_code];
  for (int k = 0; k < 3; ++k) {
    measurement->force(k) = GetFloat32(&input_[map_.force[k]], order);
  }
  for (int k = 0; k < 6; ++k) {
    measurement->y(k) = GetFloat32(&input_[map_.y[k]], order);
  }
  return IoResult::kFresh;
}

IoResult ModbusRig::Write(const RigCommand& command) {
  z_a_ = command.z_a;
  if (!connected_.load(std::memory_order_acquire)) return IoResult::kError;
  FlushIfNeeded();
  holding_[map_.control_word] = command.enable ? kControlEnable : 0;
  holding_[map_.sequence] = command.sequence;
  holding_[map_.session] = session_;
  RememberSent(command.sequence);
  for (int k = 0; k < 3; ++k) {
    PutFloat32(command.force(k), map_.high_word_first,
               &holding_[map_.setpoint[k]]);
  }
  PutFloat32(command.z_a, map_.high_word_first, &holding_[map_.z_a]);
  const int count = map_.holding_count();
  if (modbus_write_registers(context_, 0, count, holding_) != count) {
    OnRequestFailed();
    return IoResult::kError;
  }
  return IoResult::kFresh;
}

void ModbusRig::ReconnectLoop() {
  const auto interval = std::chrono::microseconds(
      static_cast<long>(settings_.reconnect_interval * 1e6));
  std::unique_lock<std::mutex> lock(wake_mutex_);
  while (!stopping_) {
    wake_.wait_for(lock, interval);
    if (stopping_ || connected_.load(std::memory_order_acquire)) continue;
    modbus_close(context_);
    SetTimeout(context_, kConnectTimeout);
    if (modbus_connect(context_) == 0) {
      SetTimeout(context_, settings_.response_timeout);
      flush_before_request_ = false;
      ++reconnects_;
      connected_.store(true, std::memory_order_release);
    }
  }
}

}  // namespace kcrig
