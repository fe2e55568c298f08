// One master at a time, on the rig side (the contract of README 2.4 that a
// real rig's front end implements too): a master claims an unclaimed rig
// with a non-zero session token; while it is claimed, only requests that
// carry the owner's token are obeyed and all others are refused and
// counted; the owner gives control back by request, and loses it when it
// stays silent for the command timeout or its connection closes. Nothing
// enables an unclaimed rig. Transport-free: the front end says which
// connection a request came on.
#ifndef KCRIG_EMULATOR_RIG_OWNERSHIP_H_
#define KCRIG_EMULATOR_RIG_OWNERSHIP_H_

#include <cstdint>

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
