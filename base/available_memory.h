// How much memory this process can still take before the kernel refuses it
// or kills the process: the kernel's MemAvailable, lowered by a cgroup v2
// limit (a container's) when one is set. Long computations check their
// need against it up front and refuse with one line, rather than being
// killed half-way. Never throws.
#ifndef KCRIG_BASE_AVAILABLE_MEMORY_H_
#define KCRIG_BASE_AVAILABLE_MEMORY_H_

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

namespace kcrig {
namespace internal {

// The first number in `path` (after `key` when given); `fallback` when the
// file or the number is missing ("max" in a cgroup file).
inline std::uint64_t ReadNumber(const std::string& path, const std::string& key,
                                std::uint64_t fallback) {
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (!key.empty() && line.rfind(key, 0) != 0) continue;
    std::istringstream fields(key.empty() ? line : line.substr(key.size()));
    std::uint64_t value = 0;
    return fields >> value ? value : fallback;
  }
  return fallback;
}

}  // namespace internal

inline std::uint64_t AvailableMemoryBytes() {
  constexpr std::uint64_t kUnknown = std::numeric_limits<std::uint64_t>::max();
  const std::uint64_t kib =
      internal::ReadNumber("/proc/meminfo", "MemAvailable:", kUnknown);
  std::uint64_t available = kib == kUnknown ? kUnknown : kib * 1024;
  const std::string cgroup = "/sys/fs/cgroup/";
  const std::uint64_t limit =
      internal::ReadNumber(cgroup + "memory.max", "", kUnknown);
  const std::uint64_t used =
      internal::ReadNumber(cgroup + "memory.current", "", 0);
  if (limit != kUnknown)
    available = std::min(available, limit - std::min(limit, used));
  return available;
}

}  // namespace kcrig

#endif  // KCRIG_BASE_AVAILABLE_MEMORY_H_
