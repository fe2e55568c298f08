#include "emulator/rig_ownership.h"

namespace kcrig {

RigOwnership::Verdict RigOwnership::Decide(const Request& request, double now) {
  const bool from_owner =
      owner_ != 0 && request.has_session && request.session == owner_ &&
      (owner_connection_ < 0 || request.connection == owner_connection_);
  if (owner_ == 0 && request.claim && request.has_session &&
      request.session != 0 && request.session != kOwnerHidden) {
    owner_ = request.session;
    owner_connection_ = request.connection;
  } else if (!from_owner && (owner_ != 0 || request.enable)) {
    // Claimed by another session, or an enable without a claim.
    ++refused_;
    return Verdict::kRefuse;
  }
  if (owner_ == 0) return Verdict::kObey;  // a disabled command, unclaimed
  last_request_ = now;
  if (request.release) {
    owner_ = 0;
    owner_connection_ = -1;
    return Verdict::kObeyAndRelease;
  }
  return Verdict::kObey;
}

std::uint16_t RigOwnership::VisibleOwner(int connection) const {
  if (owner_ == 0 || owner_connection_ < 0 || connection == owner_connection_) {
    return owner_;
  }
  return kOwnerHidden;
}

bool RigOwnership::ConnectionClosed(int connection) {
  if (owner_ == 0 || connection < 0 || connection != owner_connection_) {
    return false;
  }
  owner_ = 0;
  owner_connection_ = -1;
  return true;
}

bool RigOwnership::Expire(double now, double timeout) {
  if (owner_ == 0 || now - last_request_ <= timeout) return false;
  owner_ = 0;
  owner_connection_ = -1;
  return true;
}

}  // namespace kcrig
