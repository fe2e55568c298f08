#include "io_drivers/modbus_server.h"

#include <arpa/inet.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/select.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <vector>

namespace kcrig {

ModbusServer::ModbusServer(const ModbusMap& map) : map_(map) {}

ModbusServer::~ModbusServer() {
  if (listen_socket_ >= 0) close(listen_socket_);
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
  listen_socket_ = modbus_tcp_listen(context_, 8);
  if (listen_socket_ < 0) {
    return Status::Error("--modbus-tcp " + host + ":" + std::to_string(port) +
                         ": cannot listen (" + modbus_strerror(errno) + ")");
  }
  sockaddr_in address{};
  socklen_t length = sizeof(address);
  getsockname(listen_socket_, reinterpret_cast<sockaddr*>(&address), &length);
  port_ = ntohs(address.sin_port);
  return Status::Ok();
}

std::uint16_t* ModbusServer::input_registers() {
  return mapping_->tab_input_registers;
}

std::uint16_t* ModbusServer::holding_registers() {
  return mapping_->tab_registers;
}

Status ModbusServer::Serve(const std::atomic<int>& stop, double tick_interval,
                           const Hooks& hooks) {
  fd_set clients;
  FD_ZERO(&clients);
  FD_SET(listen_socket_, &clients);
  int max_fd = listen_socket_;
  std::vector<std::uint8_t> query(MODBUS_TCP_MAX_ADU_LENGTH);
  const int header = modbus_get_header_length(context_);
  while (stop.load() == 0) {
    fd_set ready = clients;
    timeval timeout;
    timeout.tv_sec = 0;
    timeout.tv_usec = static_cast<long>(tick_interval * 1e6);
    const int count = select(max_fd + 1, &ready, nullptr, nullptr, &timeout);
    if (count < 0 && errno != EINTR) {
      return Status::Error(std::string("modbus server: select: ") +
                           std::strerror(errno));
    }
    hooks.tick();
    if (count <= 0) continue;
    for (int fd = 0; fd <= max_fd; ++fd) {
      if (!FD_ISSET(fd, &ready)) continue;
      if (fd == listen_socket_) {
        const int client = accept(listen_socket_, nullptr, nullptr);
        if (client >= FD_SETSIZE) {  // select() cannot watch it
          close(client);
        } else if (client >= 0) {
          // Without TCP_NODELAY, Nagle holds each small reply until the
          // client acknowledges the previous one: one cycle late.
          const int on = 1;
          setsockopt(client, IPPROTO_TCP, TCP_NODELAY, &on, sizeof(on));
          FD_SET(client, &clients);
          max_fd = std::max(max_fd, client);
        }
        continue;
      }
      modbus_set_socket(context_, fd);
      const int length = modbus_receive(context_, query.data());
      if (length < 0) {  // closed or broken: forget the client
        close(fd);
        FD_CLR(fd, &clients);
        continue;
      }
      if (length == 0) continue;  // not for this unit
      const std::uint8_t function = query[header];
      if (function == MODBUS_FC_READ_INPUT_REGISTERS) hooks.before_input_read();
      modbus_reply(context_, query.data(), length, mapping_);
      if (function == MODBUS_FC_WRITE_MULTIPLE_REGISTERS ||
          function == MODBUS_FC_WRITE_SINGLE_REGISTER) {
        hooks.after_holding_write();
      }
    }
  }
  for (int fd = 0; fd <= max_fd; ++fd) {
    if (fd != listen_socket_ && FD_ISSET(fd, &clients)) close(fd);
  }
  return Status::Ok();
}

}  // namespace kcrig
