#include "rt_core/runtime/realtime.h"

#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>

namespace kcrig {
namespace {

// The calling thread's CPU set before SetUpRealtime pinned it.
thread_local cpu_set_t g_saved_affinity;
thread_local bool g_affinity_saved = false;
// The open /dev/cpu_dma_latency request (released when closed).
int g_dma_latency_fd = -1;

// Touches a stack region once so that the cycle does not fault it in later.
void PrefaultStack() {
  constexpr std::size_t kBytes = 256 * 1024;
  volatile unsigned char buffer[kBytes];
  for (std::size_t i = 0; i < kBytes; i += 4096) buffer[i] = 0;
  (void)buffer[0];  // a volatile read: the writes above are not dead
}

}  // namespace

RealtimeReport SetUpRealtime(const RealtimeOptions& options) {
  RealtimeReport report;
  if (options.lock_memory) {
    if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
      report.locked = true;
    } else {
      report.warnings.push_back(
          std::string("mlockall failed (") + std::strerror(errno) +
          "): memory not locked, page faults can delay cycles (raise "
          "RLIMIT_MEMLOCK or run with CAP_IPC_LOCK)");
    }
  }
  PrefaultStack();
  if (options.no_cpu_idle && g_dma_latency_fd < 0) {
    const int fd = open("/dev/cpu_dma_latency", O_RDWR | O_CLOEXEC);
    const std::int32_t zero = 0;
    if (fd >= 0 && write(fd, &zero, sizeof(zero)) == sizeof(zero)) {
      g_dma_latency_fd = fd;
      report.no_cpu_idle = true;
    } else {
      report.warnings.push_back(
          std::string("/dev/cpu_dma_latency refused (") + std::strerror(errno) +
          "): CPUs may enter deep idle states, whose exit adds wake-up "
          "latency");
      if (fd >= 0) close(fd);
    }
  }
  if (options.cpu >= 0) {
    g_affinity_saved =
        pthread_getaffinity_np(pthread_self(), sizeof(g_saved_affinity),
                               &g_saved_affinity) == 0;
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(options.cpu, &set);
    const int error = pthread_setaffinity_np(pthread_self(), sizeof(set), &set);
    if (error == 0) {
      report.affinity = true;
    } else {
      report.warnings.push_back("CPU affinity " + std::to_string(options.cpu) +
                                " refused (" + std::strerror(error) +
                                "): the loop may migrate between CPUs");
    }
  }
  if (options.priority > 0) {
    sched_param param{};
    param.sched_priority = options.priority;
    const int error = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);
    if (error == 0) {
      report.fifo = true;
    } else {
      report.warnings.push_back(
          "SCHED_FIFO priority " + std::to_string(options.priority) +
          " refused (" + std::strerror(error) +
          "): running under the time-sharing scheduler, wake-up latency "
          "is not bounded (run as root or with CAP_SYS_NICE / rtprio)");
    }
  }
  return report;
}

void LeaveRealtime() {
  sched_param param{};
  param.sched_priority = 0;
  pthread_setschedparam(pthread_self(), SCHED_OTHER, &param);
  if (g_affinity_saved) {
    pthread_setaffinity_np(pthread_self(), sizeof(g_saved_affinity),
                           &g_saved_affinity);
    g_affinity_saved = false;
  }
  if (g_dma_latency_fd >= 0) {
    close(g_dma_latency_fd);
    g_dma_latency_fd = -1;
  }
  munlockall();
}

void KeepOffCpu(int cpu) {
  cpu_set_t set;
  if (cpu < 0 || cpu >= CPU_SETSIZE ||
      pthread_getaffinity_np(pthread_self(), sizeof(set), &set) != 0 ||
      !CPU_ISSET(cpu, &set)) {
    return;
  }
  CPU_CLR(cpu, &set);
  if (CPU_COUNT(&set) > 0) {
    pthread_setaffinity_np(pthread_self(), sizeof(set), &set);
  }
}

}  // namespace kcrig
