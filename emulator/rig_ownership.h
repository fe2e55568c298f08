// One master at a time, on the rig side (the contract of docs/rig.md, Modbus,
// that a real rig's front end implements too): a master claims an unclaimed rig
// with a non-zero session token; while it is claimed, only requests that
// carry the owner's token on the owner's connection are obeyed, and all
// others are refused and counted, so a token read or guessed by another
// client is worth nothing. Only the owner's connection is told the token
// (VisibleOwner). The owner gives control back by request, and loses it
// when it stays silent for the claim timeout or its connection closes.
// Nothing enables an unclaimed rig. Transport-free: the front end says
// which connection a request came on (-1 on a CAN bus, 1 on an RTU line:
// on a shared wire the token is all that names the owner).
#ifndef KCRIG_EMULATOR_RIG_OWNERSHIP_H_
#define KCRIG_EMULATOR_RIG_OWNERSHIP_H_

#include <cstdint>

#include "rt_core/model/rig_signals.h"

namespace kcrig {

class RigOwnership {
 public:
  struct Request {
    bool has_session = false;  // the request itself carries a session token
    std::uint16_t session = 0;
    bool claim = false;
    bool release = false;
    bool enable = false;
    int connection = -1;  // -1: the transport has no connections
  };
  enum class Verdict {
    kObey,
    kObeyAndRelease,  // the owner's last request: disable, then unclaimed
    kRefuse,
  };

  // Decides on one request received at `now` [s]; refusals are counted.
  Verdict Decide(const Request& request, double now);
  // Ends the claim when the owner's connection closed; true if it did.
  bool ConnectionClosed(int connection);
  // Ends the claim when the owner was silent for more than `timeout` [s];
  // true if it did.
  bool Expire(double now, double timeout);

  // The owner register as `connection` may read it: the token for the
  // owner's own connection (and on a shared bus), kOwnerHidden to any
  // other while the rig is claimed, 0 when it is not.
  std::uint16_t VisibleOwner(int connection) const;
  // Whether `connection` is the owner's (never true on a shared bus).
  bool IsOwnerConnection(int connection) const {
    return owner_ != 0 && connection >= 0 && connection == owner_connection_;
  }

  std::uint16_t owner() const { return owner_; }
  std::uint16_t refused() const { return refused_; }  // mod 2^16

 private:
  std::uint16_t owner_ = 0;
  int owner_connection_ = -1;
  double last_request_ = 0;
  std::uint16_t refused_ = 0;
};

}  // namespace kcrig

#endif  // KCRIG_EMULATOR_RIG_OWNERSHIP_H_
