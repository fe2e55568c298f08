// The Modbus transport: kcrig as Modbus master (libmodbus) of the rig, over
// TCP or RTU, behind the loop's RigInterface. Each cycle reads the input
// registers (one function-4 request) and writes the holding registers (one
// function-16 request), each bounded by the response timeout of
// config/rig.yaml. A timeout or exception is a missed sample for the
// watchdog; a lost connection is closed in the cycle and reopened by a
// background thread, never inside the cycle. One master: Activate claims
// the rig with a random session token carried in every write, and every
// read checks that the rig still names this session as its owner and
// echoes a sequence this controller sent.
#ifndef KCRIG_IO_DRIVERS_MODBUS_RIG_H_
#define KCRIG_IO_DRIVERS_MODBUS_RIG_H_

#include <array>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

#include "io_drivers/modbus_map.h"
#include "io_drivers/transport_config.h"
#include "rt_core/runtime/rig_interface.h"

typedef struct _modbus modbus_t;

namespace kcrig {

// modbus-tcp://HOST:PORT or modbus-rtu://DEVICE (e.g.
// modbus-rtu:///dev/ttyUSB0).
struct ModbusEndpoint {
  bool rtu = false;
  std::string host;    // TCP
  int port = 502;      // TCP
  std::string device;  // RTU
};

Status ParseModbusUri(const std::string& uri, ModbusEndpoint* endpoint);

// Over RTU, whether one cycle's read and write fit `period` on the wire at
// the line's baud rate (with the 3.5-character silences between frames),
// and the read's request and reply fit the response timeout; the error
// gives both times.
Status CheckRtuWireTime(const ModbusEndpoint& endpoint, const ModbusMap& map,
                        const ModbusSettings& settings, double period);

class ModbusRig : public RigInterface {
 public:
  ModbusRig(const ModbusEndpoint& endpoint, const ModbusMap& map,
            const ModbusSettings& settings);
  ~ModbusRig() override;

  Status Configure() override;
  Status Activate() override;
  Status Deactivate() override;
  void OnError() override;
  IoResult Read(RigMeasurement* measurement) override;
  IoResult Write(const RigCommand& command) override;
  std::string Describe() const override;
  std::string CountersJson() const override;

  // Reconnections made by the background thread.
  int reconnects() const { return reconnects_.load(); }
  // This controller's session token (non-zero).
  std::uint16_t session() const { return session_; }

 private:
  // Handles a failed request: a broken link is closed and handed to the
  // reconnect thread; a timeout flushes late replies.
  void OnRequestFailed();
  void FlushIfNeeded();
  void ReconnectLoop();
  Status WriteControl(std::uint16_t control_word, int attempts);
  // The error for a write the rig refused (exception 6): another master,
  // or the rig ended this controller's claim (its fault, named).
  Status ClaimedElsewhere();
  // Whether the last read shows another master; records what it saw.
  bool ForeignMasterSeen();
  void RememberSent(std::uint16_t sequence);

  ModbusEndpoint endpoint_;
  ModbusMap map_;
  ModbusSettings settings_;
  modbus_t* context_ = nullptr;
  // The cycle uses context_ only while connected_; the reconnect thread only
  // while not.
  std::atomic<bool> connected_{false};
  std::atomic<bool> stopping_{false};
  std::atomic<int> reconnects_{0};
  std::thread reconnect_thread_;
  std::mutex wake_mutex_;
  std::condition_variable wake_;
  std::uint16_t input_[125] = {};
  std::uint16_t holding_[123] = {};
  std::uint32_t last_sample_ = 0;
  bool have_sample_ = false;
  bool flush_before_request_ = false;
  std::uint16_t sequence_ = 0;
  double z_a_ = 0;  // last commanded acting height, kept by control writes
  std::uint16_t session_;
  // The sequences of the last writes: the rig's echo must be one of them.
  std::array<std::uint16_t, 64> sent_{};
  size_t sent_count_ = 0;
  // What the read that found another master saw (for the trip message).
  std::uint16_t foreign_owner_ = 0;
  std::uint16_t foreign_echo_ = 0;
  bool foreign_echo_ours_ = true;
  bool foreign_ = false;
  // The rig's refused_writes register when this controller took the claim,
  // and how many writes it refused since (anyone's, mod 2^16).
  std::uint16_t refused_at_claim_ = 0;
  std::uint16_t refused_writes_ = 0;
  // Reads answered after modbus.response_timeout. libmodbus bounds the whole
  // reply by it (byte timeout 0), so such a read means this thread ran late
  // after its wait (a late wake-up: the machine's scheduling, a VM's stolen
  // time), by at least the excess; not a rig that libmodbus waited for.
  std::int64_t late_replies_ = 0;
  double late_reply_max_s_ = 0;
};

}  // namespace kcrig

#endif  // KCRIG_IO_DRIVERS_MODBUS_RIG_H_
