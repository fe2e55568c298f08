// FNV-1a, 64 bits: a fingerprint of bytes that is the same on every
// platform and build, printed as 16 hex digits. For recognising an input
// again (a geometry, a checkpoint's config), not for security.
#ifndef KCRIG_BASE_FNV1A_H_
#define KCRIG_BASE_FNV1A_H_

#include <cinttypes>
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>

namespace kcrig {

class Fnv1a {
 public:
  void Mix(std::string_view bytes) {
    for (unsigned char c : bytes) {
      hash_ ^= c;
      hash_ *= 1099511628211ULL;
    }
  }
  std::string Hex() const {
    char hex[17];
    std::snprintf(hex, sizeof(hex), "%016" PRIx64, hash_);
    return hex;
  }

 private:
  std::uint64_t hash_ = 1469598103934665603ULL;
};

}  // namespace kcrig

#endif  // KCRIG_BASE_FNV1A_H_
