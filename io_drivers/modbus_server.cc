#include "io_drivers/modbus_server.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <vector>

#include "rt_core/runtime/clock.h"

namespace kcrig {
namespace {

double Now() { return SystemClock()->Seconds(); }

// MBAP header: transaction id, protocol id (0), length of what follows the
// length field (unit id + PDU), unit id.
constexpr int kHeaderLength = 7;
constexpr int kMaxPduLength = MODBUS_TCP_MAX_ADU_LENGTH - kHeaderLength;

std::uint16_t Word(const std::uint8_t* bytes) {
  return static_cast<std::uint16_t>((bytes[0] << 8) | bytes[1]);
}

// One connection: its bytes so far and since when a frame is unfinished.
struct Client {
  int fd = -1;
  int id = 0;
  std::array<std::uint8_t, MODBUS_TCP_MAX_ADU_LENGTH> frame{};
  int received = 0;
  double partial_since = 0;
  double last_request = 0;  // when it connected or sent its last whole frame

  // Bytes of the whole frame once its header is in (0 before); -1 when the
  // header is not Modbus TCP.
  int FrameLength() const {
    if (received < kHeaderLength) return 0;
    const int length = Word(&frame[4]);
    if (Word(&frame[2]) != 0 || length < 2 || length > kMaxPduLength + 1) {
      return -1;
    }
    return 6 + length;
  }
};

// The holding registers a write request (function 6, 16, 22 or 23) would
// set, as (address, values); false when the frame does not hold them all.
// FC 22 (mask write) is resolved against the current table.
bool HoldingWrite(const std::uint8_t* pdu, int pdu_length,
                  const std::uint16_t* table, int table_size, int* address,
                  std::vector<std::uint16_t>* values) {
  values->clear();
  auto words_from = [&](int offset, int count) {
    if (offset + 2 * count > pdu_length) return false;
    for (int k = 0; k < count; ++k)
      values->push_back(Word(pdu + offset + 2 * k));
    return true;
  };
  switch (pdu[0]) {
    case MODBUS_FC_WRITE_SINGLE_REGISTER:
      if (pdu_length < 5) return false;
      *address = Word(pdu + 1);
      return words_from(3, 1);
    case MODBUS_FC_WRITE_MULTIPLE_REGISTERS:
      if (pdu_length < 6) return false;
      *address = Word(pdu + 1);
      return words_from(6, Word(pdu + 3));
    case MODBUS_FC_WRITE_AND_READ_REGISTERS:
      if (pdu_length < 10) return false;
      *address = Word(pdu + 5);
      return words_from(10, Word(pdu + 7));
    case MODBUS_FC_MASK_WRITE_REGISTER: {
      if (pdu_length < 7) return false;
      *address = Word(pdu + 1);
      if (*address >= table_size) return false;
      const std::uint16_t and_mask = Word(pdu + 3), or_mask = Word(pdu + 5);
      values->push_back(static_cast<std::uint16_t>(
          (table[*address] & and_mask) | (or_mask & ~and_mask)));
      return true;
    }
  }
  return false;
}

// Answers one whole request frame (the ADU as libmodbus frames it for the
// context's backend: MBAP header or RTU address before the PDU, RTU CRC
// after it); false when the reply could not be sent.
bool AnswerRequest(modbus_t* context, modbus_mapping_t* mapping,
                   const ModbusServer::Hooks& hooks, int client,
                   const std::uint8_t* frame, int length,
                   std::vector<std::uint16_t>* values) {
  const int header = modbus_get_header_length(context);
  const int trailer = header == kHeaderLength ? 0 : 2;  // RTU: the CRC
  const std::uint8_t* pdu = frame + header;
  const int pdu_length = length - header - trailer;
  const int unit = frame[header - 1];
  if (pdu_length < 1 ||
      (unit != modbus_get_slave(context) && unit != 0 && unit != 0xff)) {
    return true;  // for another unit behind a gateway: not ours to answer
  }
  if (pdu[0] == MODBUS_FC_READ_INPUT_REGISTERS) hooks.before_input_read(client);
  if ((pdu[0] == MODBUS_FC_READ_HOLDING_REGISTERS ||
       pdu[0] == MODBUS_FC_WRITE_AND_READ_REGISTERS) &&
      hooks.before_holding_read) {
    hooks.before_holding_read(client);
  }
  const bool writes_holding = pdu[0] == MODBUS_FC_WRITE_SINGLE_REGISTER ||
                              pdu[0] == MODBUS_FC_WRITE_MULTIPLE_REGISTERS ||
                              pdu[0] == MODBUS_FC_WRITE_AND_READ_REGISTERS ||
                              pdu[0] == MODBUS_FC_MASK_WRITE_REGISTER;
  int address = 0;
  if (writes_holding) {
    // A write the frame does not hold whole is never applied.
    if (!HoldingWrite(pdu, pdu_length, mapping->tab_registers,
                      mapping->nb_registers, &address, values)) {
      return modbus_reply_exception(context, frame,
                                    MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE) >= 0;
    }
    if (hooks.accept_holding_write &&
        !hooks.accept_holding_write(client, address,
                                    static_cast<int>(values->size()),
                                    values->data())) {
      return modbus_reply_exception(context, frame,
                                    MODBUS_EXCEPTION_SLAVE_OR_SERVER_BUSY) >= 0;
    }
  }
  return modbus_reply(context, frame, length, mapping) >= 0;
}

}  // namespace

ModbusServer::ModbusServer(const ModbusMap& map) : map_(map) {}

ModbusServer::~ModbusServer() {
  if (listen_socket_ >= 0) close(listen_socket_);
  if (!device_.empty()) modbus_close(context_);
  if (mapping_ != nullptr) modbus_mapping_free(mapping_);
  if (context_ != nullptr) modbus_free(context_);
}

Status ModbusServer::Listen(const std::string& host, int port) {
  context_ = modbus_new_tcp(host.c_str(), port);
  if (context_ == nullptr) {
    return Status::Error("modbus server: " +
                         std::string(modbus_strerror(errno)));
  }
  modbus_set_slave(context_, map_.unit_id);
  mapping_ = modbus_mapping_new_start_address(
      0, 0, 0, 0, 0, map_.holding_count(), 0, map_.input_count());
  if (mapping_ == nullptr) {
    return Status::Error("modbus server: cannot allocate the register map");
  }
  // A deep backlog: a burst of connections (a scan, a flood) must not make
  // the master's connect wait out a dropped SYN's one-second retry.
  listen_socket_ = modbus_tcp_listen(context_, 128);
  if (listen_socket_ < 0) {
    return Status::Error("--modbus-tcp " + host + ":" + std::to_string(port) +
                         ": cannot listen (" + modbus_strerror(errno) + ")");
  }
  fcntl(listen_socket_, F_SETFL, fcntl(listen_socket_, F_GETFL) | O_NONBLOCK);
  sockaddr_in address{};
  socklen_t length = sizeof(address);
  getsockname(listen_socket_, reinterpret_cast<sockaddr*>(&address), &length);
  port_ = ntohs(address.sin_port);
  return Status::Ok();
}

Status ModbusServer::OpenSerial(const std::string& device,
                                const ModbusSettings& serial) {
  const std::string what = "--modbus-rtu " + device;
  context_ = modbus_new_rtu(device.c_str(), serial.baud, serial.parity,
                            serial.data_bits, serial.stop_bits);
  if (context_ == nullptr) {
    return Status::Error(what + ": " + modbus_strerror(errno));
  }
  modbus_set_slave(context_, map_.unit_id);
  // A frame's bytes follow each other within a few character times; a
  // line that stops mid-frame is given up on soon (the master retries).
  modbus_set_byte_timeout(context_, 0, 20000);
  mapping_ = modbus_mapping_new_start_address(
      0, 0, 0, 0, 0, map_.holding_count(), 0, map_.input_count());
  if (mapping_ == nullptr) {
    return Status::Error("modbus server: cannot allocate the register map");
  }
  if (modbus_connect(context_) == -1) {
    return Status::Error(what + ": cannot open (" + modbus_strerror(errno) +
                         ")");
  }
  device_ = device;
  return Status::Ok();
}

std::uint16_t* ModbusServer::input_registers() {
  return mapping_->tab_input_registers;
}

std::uint16_t* ModbusServer::holding_registers() {
  return mapping_->tab_registers;
}

namespace {

// The server's loop state; one instance per Serve().
class Connections {
 public:
  Connections(modbus_t* context, modbus_mapping_t* mapping, int listen_socket,
              const ModbusServer::Hooks& hooks)
      : context_(context),
        mapping_(mapping),
        listen_socket_(listen_socket),
        hooks_(hooks) {}

  ~Connections() {
    for (Client& c : clients_) close(c.fd);
  }

  // Waits up to `timeout` [s] and serves what arrived.
  Status Poll(double timeout) {
    std::vector<pollfd> fds;
    const double now = Now();
    const bool accepting = now >= accept_paused_until_;
    if (accepting) fds.push_back({listen_socket_, POLLIN, 0});
    for (const Client& c : clients_) fds.push_back({c.fd, POLLIN, 0});
    const int count =
        poll(fds.data(), fds.size(), static_cast<int>(timeout * 1e3 + 0.5));
    if (count < 0 && errno != EINTR) {
      return Status::Error(std::string("modbus server: poll: ") +
                           std::strerror(errno));
    }
    hooks_.tick();
    std::vector<int> ready;
    for (const pollfd& p : fds) {
      if (p.revents != 0 && p.fd != listen_socket_) ready.push_back(p.fd);
    }
    for (int fd : ready) Receive(fd);
    DropStalledFrames(Now());
    CloseIdle(Now());
    // Drain the backlog: a full one drops connection attempts, which the
    // client's kernel retries only after a second or more.
    if (accepting && count > 0 && (fds[0].revents & POLLIN)) {
      for (int k = 0; k < 64 && Accept(); ++k) {
      }
    }
    return Status::Ok();
  }

 private:
  // Accepts one pending connection; false when none was pending.
  bool Accept() {
    const int fd = accept4(listen_socket_, nullptr, nullptr, SOCK_NONBLOCK);
    if (fd < 0) {
      // Out of descriptors: the pending connection stays readable, so stop
      // watching the listener for a while instead of spinning on it.
      if (errno == EMFILE || errno == ENFILE || errno == ENOBUFS ||
          errno == ENOMEM) {
        accept_paused_until_ = Now() + 0.1;
      }
      return false;
    }
    if (static_cast<int>(clients_.size()) >= ModbusServer::kMaxClients &&
        !MakeRoom()) {
      char line[128];
      std::snprintf(line, sizeof(line),
                    "refused a connection: it serves %d connections and none "
                    "has been idle for %.0f s",
                    ModbusServer::kMaxClients, ModbusServer::kEvictableIdle);
      Note(line);
      close(fd);
      return true;
    }
    // Without TCP_NODELAY, Nagle holds each small reply until the client
    // acknowledges the previous one: one cycle late.
    const int on = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &on, sizeof(on));
    Client client;
    client.fd = fd;
    client.id = ++last_id_;
    client.last_request = Now();
    clients_.push_back(client);
    return true;
  }

  bool Protected(const Client& c) const {
    return hooks_.is_protected && hooks_.is_protected(c.id);
  }

  // Closes the longest idle unprotected connection if it has been idle
  // for kEvictableIdle; false if none has.
  bool MakeRoom() {
    const double now = Now();
    const Client* idlest = nullptr;
    for (const Client& c : clients_) {
      if (!Protected(c) &&
          now - c.last_request >= ModbusServer::kEvictableIdle &&
          (idlest == nullptr || c.last_request < idlest->last_request)) {
        idlest = &c;
      }
    }
    if (idlest == nullptr) return false;
    char line[160];
    std::snprintf(line, sizeof(line),
                  "%d connections (the most it serves): closed client %d, "
                  "idle %.1f s, for a new one",
                  ModbusServer::kMaxClients, idlest->id,
                  now - idlest->last_request);
    Note(line);
    Close(idlest->fd);
    return true;
  }

  // Closes unprotected connections without a whole request for
  // kIdleTimeout (an idle or half-open client holds a place for nothing).
  void CloseIdle(double now) {
    std::vector<int> idle;
    for (const Client& c : clients_) {
      if (!Protected(c) && now - c.last_request > ModbusServer::kIdleTimeout) {
        idle.push_back(c.fd);
      }
    }
    if (!idle.empty()) {
      Note("closed " + std::to_string(idle.size()) +
           " connection(s) idle for more than " +
           std::to_string(static_cast<int>(ModbusServer::kIdleTimeout)) + " s");
    }
    for (int fd : idle) Close(fd);
  }

  // At most one line a second: a flood of connections is one line, not a
  // flood of lines.
  void Note(const std::string& line) {
    const double now = Now();
    if (!hooks_.note) return;
    if (now - last_note_ < 1.0) {
      ++notes_held_;
      return;
    }
    hooks_.note(notes_held_ > 0
                    ? line + " (and " + std::to_string(notes_held_) +
                          " more like it in the last second)"
                    : line);
    last_note_ = now;
    notes_held_ = 0;
  }

  Client* Find(int fd) {
    for (Client& c : clients_) {
      if (c.fd == fd) return &c;
    }
    return nullptr;
  }

  void Close(int fd) {
    for (size_t i = 0; i < clients_.size(); ++i) {
      if (clients_[i].fd != fd) continue;
      const int id = clients_[i].id;
      close(fd);
      clients_.erase(clients_.begin() + static_cast<long>(i));
      if (hooks_.client_closed) hooks_.client_closed(id);
      return;
    }
  }

  // Reads what the socket has and answers the whole frames in it, a few per
  // wake-up so that a flooding client cannot starve the others.
  void Receive(int fd) {
    constexpr int kFramesPerWake = 4;
    for (int answered = 0; answered < kFramesPerWake;) {
      Client* c = Find(fd);
      if (c == nullptr) return;
      const int length = c->FrameLength();
      if (length < 0) return Close(fd);
      const int wanted =
          length > 0 ? length - c->received : kHeaderLength - c->received;
      const ssize_t got = recv(fd, c->frame.data() + c->received,
                               static_cast<size_t>(wanted), 0);
      if (got == 0 || (got < 0 && errno != EAGAIN && errno != EWOULDBLOCK &&
                       errno != EINTR)) {
        return Close(fd);
      }
      if (got < 0) return;  // nothing more for now
      if (c->received == 0) c->partial_since = Now();
      c->received += static_cast<int>(got);
      if (c->FrameLength() > 0 && c->received == c->FrameLength()) {
        const int frame_length = c->received;
        c->received = 0;
        c->last_request = Now();
        ++answered;
        modbus_set_socket(context_, fd);
        if (!AnswerRequest(context_, mapping_, hooks_, c->id, c->frame.data(),
                           frame_length, &values_)) {
          return Close(fd);
        }
      }
    }
  }

  void DropStalledFrames(double now) {
    std::vector<int> stalled;
    for (const Client& c : clients_) {
      if (c.received > 0 &&
          now - c.partial_since > ModbusServer::kPartialFrameTimeout) {
        stalled.push_back(c.fd);
      }
    }
    for (int fd : stalled) Close(fd);
  }

  modbus_t* context_;
  modbus_mapping_t* mapping_;
  int listen_socket_;
  const ModbusServer::Hooks& hooks_;
  std::vector<Client> clients_;
  std::vector<std::uint16_t> values_;
  int last_id_ = 0;
  double accept_paused_until_ = 0;
  double last_note_ = -1e9;
  int notes_held_ = 0;
};

}  // namespace

Status ModbusServer::ServeSerial(const std::atomic<int>& stop,
                                 double tick_interval, const Hooks& hooks) {
  const int fd = modbus_get_socket(context_);
  std::vector<std::uint8_t> request(MODBUS_RTU_MAX_ADU_LENGTH);
  std::vector<std::uint16_t> values;
  while (stop.load() == 0) {
    pollfd line{fd, POLLIN, 0};
    const int count =
        poll(&line, 1, static_cast<int>(tick_interval * 1e3 + 0.5));
    if (count < 0 && errno != EINTR) {
      return Status::Error(device_ + ": poll: " + std::strerror(errno));
    }
    hooks.tick();
    if (count <= 0) continue;
    if (line.revents & (POLLHUP | POLLERR | POLLNVAL)) {
      return Status::Error(device_ + ": the serial line closed");
    }
    // 0: a frame for another unit; -1: a bad CRC or a frame cut short.
    const int length = modbus_receive(context_, request.data());
    if (length > 0) {
      AnswerRequest(context_, mapping_, hooks, 1, request.data(), length,
                    &values);
    }
  }
  return Status::Ok();
}

Status ModbusServer::Serve(const std::atomic<int>& stop, double tick_interval,
                           const Hooks& hooks) {
  if (!device_.empty()) return ServeSerial(stop, tick_interval, hooks);
  Connections connections(context_, mapping_, listen_socket_, hooks);
  while (stop.load() == 0) {
    const Status status = connections.Poll(tick_interval);
    if (!status.ok()) return status;
  }
  return Status::Ok();
}

}  // namespace kcrig
