// What the operator console shows, kept apart from how it is served: a rig
// session's cycle records (from the logger thread, RunMonitor) turned into
// 50 Hz bins with each signal's full-rate min, max and last value (no spike
// hidden by the decimation), the safety margins (peak since the last
// update), the phase, the trip and the loop's timing so far; and a
// campaign's stages, iterations and report. Each change becomes a message
// (Server-Sent Events text) in a bounded log that every viewer reads at
// its own pace; a viewer that falls out of the log has stalled and is
// dropped. A viewer that joins late starts from a snapshot of the state.
// Memory is bounded whatever the run's length or the viewers do.
#ifndef KCRIG_CONSOLE_LIVE_FEED_H_
#define KCRIG_CONSOLE_LIVE_FEED_H_

#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

#include "hil/rig_session.h"
#include "rt_core/runtime/control_loop.h"
#include "rt_core/runtime/timing_statistics.h"

namespace kcrig {

class LiveFeed final : public RunMonitor {
 public:
  // The signals of a bin, in this order: commanded force (3), measured
  // force (3), the six channels relative to the rest pose (6), the live
  // model prediction (6). SI units.
  static constexpr int kSignals = 18;

  struct Options {
    double bin_seconds = 0.02;  // of run time: 50 Hz
    // Wall time between two updates of the viewers [s].
    double update_seconds = 0.1;
    // At most this many bins in one update: a run on the virtual clock,
    // faster than real time, has its bins merged (min of mins, max of
    // maxes) rather than flood the viewers.
    int max_bins_per_update = 50;
    // The current run's bins a late viewer receives; beyond it adjacent
    // bins are merged, so the whole run stays (coarser).
    int history_bins = 3000;
    // The message log: what a viewer may lag behind before it is dropped.
    std::size_t max_messages = 600;
    std::size_t max_log_bytes = 16u << 20;
    // Called once (from the failing thread) when the feed cannot go on
    // (out of memory): the run goes on without it.
    std::function<void(const std::string&)> on_failure;
  };

  explicit LiveFeed(Options options);

  // RunMonitor: the session's thread and the logger's.
  void RunStarted(const Run& run) override;
  void CycleLogged(const CycleRecord& record) override;
  void RunEnded(bool completed, const std::string& outcome,
                const LoopResult& loop) override;

  // The command around the runs (any thread).
  void Title(const std::string& command);
  void Stage(const std::string& text);
  // Sends a stage held back by the rate limit once its time has come (a
  // viewer's stream calls it).
  void FlushStage();
  // One iteration of campaign.json ("iterations"' entry), as it lands.
  void Iteration(const std::string& entry_json);
  void ReportWritten(const std::string& path);
  void Note(const std::string& line);
  // The command is ending: the last message; readers then see end().
  void End(const std::string& outcome);

  // For a viewer's stream: the state to start from (one SSE message) and
  // the sequence number it covers.
  std::string Snapshot(std::uint64_t* seq) const;
  // Appends the messages after *seq to `out` (about kMaxReadBytes at most
  // per call, whatever `out` held), waiting up to `wait` for one.
  // kStalled: *seq has fallen out of the log (drop the viewer); kEnded:
  // `out` holds all there will be.
  enum class Read { kMessages, kStalled, kEnded };
  Read ReadAfter(std::uint64_t* seq, std::string* out,
                 std::chrono::milliseconds wait) const;

  // A viewer's read copies at most about this much at once.
  static constexpr std::size_t kMaxReadBytes = 256u << 10;

  // Memory the log and the history hold [bytes] (tests).
  std::size_t held_bytes() const;

 private:
  struct Bin {
    double t0 = 0, t1 = 0;
    std::array<float, kSignals> lo{}, hi{}, last{};
    void Merge(const Bin& later);
  };

  template <typename Work>
  void Guarded(Work work);
  void Start(const Run& run);
  void Ingest(const CycleRecord& record);
  void Margins(const CycleRecord& record, const double* v);
  void CloseBin();
  void PublishUpdate(bool force);
  void PublishTrip(const CycleRecord& record);
  std::string StatusJson() const;
  void Publish(const char* event, std::string data);  // needs mutex_
  void PublishStageIfDue();                           // needs mutex_
  void Fail(const char* what);
  static std::string BinsJson(const std::vector<Bin>& bins);

  Options options_;

  // The logger thread's own (RunStarted/RunEnded are ordered with it by
  // the logger's start and join).
  Run run_;
  bool running_ = false;
  Bin bin_;
  std::int64_t bin_index_ = -1;
  std::vector<Bin> unsent_;
  std::array<double, 6> tare_sum_{};
  std::int64_t tare_count_ = 0;
  std::array<double, 6> first_y_{};
  std::array<double, 3> last_command_{};
  bool have_command_ = false;
  std::int64_t not_fresh_ = 0;
  std::int64_t next_cycle_ = 0;
  TimingStatistics wakeup_;
  std::chrono::steady_clock::time_point last_update_{};
  std::atomic<bool> failed_{false};  // set by any thread, once

  // Shared with the viewers' threads.
  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  struct Message {
    std::uint64_t seq;
    std::string text;
  };
  std::deque<Message> log_;
  std::size_t log_bytes_ = 0;
  std::uint64_t next_seq_ = 1;
  bool ended_ = false;
  std::chrono::steady_clock::time_point last_stage_{};
  bool stage_pending_ = false;
  // The state a late viewer starts from.
  std::string title_json_ = "{}";
  std::string run_json_ = "null";
  std::string status_json_ = "null";
  std::string trip_json_ = "null";
  std::string run_end_json_ = "null";
  std::string stage_json_ = "null";
  std::string report_json_ = "null";
  std::string end_json_ = "null";
  std::vector<std::string> iterations_;
  std::vector<std::string> notes_;
  std::vector<Bin> history_;

  // Margins as fractions of each limit (1: at it), peak since the last
  // update, and the state of the newest record (the logger thread's).
  struct Live {
    double t = 0;
    std::int64_t cycles = 0, skipped = 0, overruns = 0;
    RunPhase phase = RunPhase::kTare;
    SafetyState safety = SafetyState::kNormal;
    std::array<double, 3> force{}, rate{}, tracking{};
    std::array<double, 6> limit{}, error{};
    double watchdog = 0;
  } live_;
  bool tripped_ = false;
  TripCause trip_cause_ = TripCause::kNone;
};

}  // namespace kcrig

#endif  // KCRIG_CONSOLE_LIVE_FEED_H_
