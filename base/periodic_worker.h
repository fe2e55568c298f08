// A thread that runs one piece of work every interval until stopped, and
// once more after the stop was asked for, so that whatever a producer
// queued before Stop is still handled. The writers of the streamed logs
// (run.csv, can.log) drain their rings on it.
#ifndef KCRIG_BASE_PERIODIC_WORKER_H_
#define KCRIG_BASE_PERIODIC_WORKER_H_

#include <atomic>
#include <chrono>
#include <functional>
#include <thread>
#include <utility>

namespace kcrig {

class PeriodicWorker {
 public:
  PeriodicWorker() = default;
  ~PeriodicWorker() { Stop(); }
  PeriodicWorker(const PeriodicWorker&) = delete;
  PeriodicWorker& operator=(const PeriodicWorker&) = delete;

  // Starts the thread (after stopping one that runs).
  void Start(std::chrono::milliseconds interval, std::function<void()> work) {
    Stop();
    stop_.store(false, std::memory_order_release);
    thread_ = std::thread([this, interval, work = std::move(work)] {
      for (;;) {
        // Read before the work: a stop asked during it gets one more pass.
        const bool last = stop_.load(std::memory_order_acquire);
        work();
        if (last) return;
        std::this_thread::sleep_for(interval);
      }
    });
  }

  // Lets the work run once more, then joins. Does nothing when not started.
  void Stop() {
    if (!thread_.joinable()) return;
    stop_.store(true, std::memory_order_release);
    thread_.join();
  }

 private:
  std::thread thread_;
  std::atomic<bool> stop_{false};
};

}  // namespace kcrig

#endif  // KCRIG_BASE_PERIODIC_WORKER_H_
