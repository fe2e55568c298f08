#include "console/live_feed.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <new>
#include <utility>

#include "base/json_writer.h"
#include "nlohmann/json.hpp"
#include "rt_core/model/channels.h"
#include "rt_core/model/excitation.h"

namespace kcrig {
namespace {

using Json = nlohmann::ordered_json;

// A number as JSON, 5 significant digits (a viewer draws, it does not
// compute); non-finite as null.
void AppendNumber(double value, std::string* out) {
  if (!std::isfinite(value)) {
    *out += "null";
    return;
  }
  char text[32];
  std::snprintf(text, sizeof(text), "%.5g", value);
  *out += text;
}

// Strings from the user (paths, a rig's name) may hold invalid UTF-8: it
// is replaced, never thrown over.
std::string Dump(const Json& doc) {
  return doc.dump(-1, ' ', false, Json::error_handler_t::replace);
}

// The larger share of a limit; a NaN stays (the page shows it red) until
// the next update, as the loop trips on one.
double Peak(double a, double b) {
  return std::isnan(a) || std::isnan(b) ? std::nan("") : std::max(a, b);
}

double Fraction(double value, double limit) {
  return limit > 0 ? std::fabs(value) / limit : 0;
}

const char* SafetyName(SafetyState state) {
  switch (state) {
    case SafetyState::kNormal:
      return "normal";
    case SafetyState::kRampDown:
      return "ramping down";
    case SafetyState::kDisabled:
      return "disabled";
  }
  return "?";
}

Json Array(const double* values, int n) {
  Json list = Json::array();
  for (int i = 0; i < n; ++i) {
    list.push_back(FiniteOrNull(values[i]));
  }
  return list;
}

}  // namespace

void LiveFeed::Bin::Merge(const Bin& later) {
  t1 = later.t1;
  for (int i = 0; i < kSignals; ++i) {
    lo[i] = std::fmin(lo[i], later.lo[i]);
    hi[i] = std::fmax(hi[i], later.hi[i]);
    last[i] = later.last[i];
  }
}

LiveFeed::LiveFeed(Options options) : options_(std::move(options)) {}

// The feed's calls come from the loop's logger and the command's thread,
// which must never see an exception of the console's: the feed stops.
template <typename Work>
void LiveFeed::Guarded(Work work) {
  try {
    work();
  } catch (const std::exception& error) {
    Fail(error.what());
  } catch (...) {
    Fail("an unknown error");
  }
}

void LiveFeed::RunStarted(const Run& run) {
  Guarded([&] { Start(run); });
}

void LiveFeed::Start(const Run& run) {
  run_ = run;
  running_ = true;
  bin_index_ = -1;
  unsent_.clear();
  tare_sum_ = {};
  tare_count_ = 0;
  have_command_ = false;
  not_fresh_ = 0;
  next_cycle_ = 0;
  wakeup_ = TimingStatistics();
  live_ = Live();
  tripped_ = false;
  trip_cause_ = TripCause::kNone;
  last_update_ = std::chrono::steady_clock::now();
  const RampExcitation<double>& e = run.excitation;
  const SafetyLimits& l = run.limits;
  Json doc = {{"rig", run.rig},
              {"log_dir", run.log_dir},
              {"period_s", run.period},
              {"duration_s", run.duration},
              {"real_time", run.real_time},
              {"excitation",
               {{"phi_deg", e.phi / kDegree},
                {"z_a_m", e.z_a},
                {"fmax_n", e.fmax},
                {"tf_s", e.duration}}},
              {"limits",
               {{"force_max_n", l.force_max},
                {"force_rate_max_n_s", l.force_rate_max},
                {"travel_max_m", l.travel_max},
                {"angle_max_rad", l.angle_max},
                {"error_position_max_m", l.error_position_max},
                {"error_angle_max_rad", l.error_angle_max},
                {"force_error_max_n", l.force_error_max},
                {"watchdog_cycles", l.watchdog_cycles}}}};
  std::lock_guard<std::mutex> lock(mutex_);
  history_.clear();
  run_json_ = Dump(doc);
  status_json_ = trip_json_ = run_end_json_ = "null";
  Publish("run", run_json_);
}

void LiveFeed::CycleLogged(const CycleRecord& record) {
  if (failed_ || !running_) return;
  Guarded([&] { Ingest(record); });
}

void LiveFeed::Ingest(const CycleRecord& r) {
  const double t = static_cast<double>(r.cycle) * run_.period;
  // Cycles skipped by overruns have no record: they count for the
  // watchdog as the loop counts them.
  const std::int64_t skipped = std::max<std::int64_t>(r.cycle - next_cycle_, 0);
  live_.skipped += skipped;
  not_fresh_ = r.fresh ? 0 : not_fresh_ + 1 + skipped;
  next_cycle_ = r.cycle + 1;
  ++live_.cycles;
  live_.t = t;
  live_.overruns = r.overruns;
  wakeup_.Record(r.wakeup_latency_ns);
  if (r.phase == RunPhase::kTare && r.fresh) {
    for (int k = 0; k < 6; ++k) tare_sum_[k] += r.y[k];
    ++tare_count_;
  }
  double v[kSignals];
  for (int k = 0; k < 3; ++k) {
    v[k] = r.commanded[k];
    v[3 + k] = r.force[k];
  }
  if (live_.cycles == 1) std::copy(r.y, r.y + 6, first_y_.begin());
  for (int k = 0; k < 6; ++k) {
    // The rest pose: the tare's mean, or until it has one the first pose.
    const double rest =
        tare_count_ > 0 ? tare_sum_[k] / tare_count_ : first_y_[k];
    v[6 + k] = r.y[k] - rest;
    v[12 + k] = r.predicted[k];
  }
  Margins(r, v);

  const auto index =
      static_cast<std::int64_t>(std::floor(t / options_.bin_seconds));
  if (index != bin_index_) {
    if (bin_index_ >= 0) CloseBin();
    bin_index_ = index;
    bin_.t0 = t;
    for (int i = 0; i < kSignals; ++i) {
      bin_.lo[i] = bin_.hi[i] = static_cast<float>(v[i]);
    }
  }
  bin_.t1 = t;
  for (int i = 0; i < kSignals; ++i) {
    const auto value = static_cast<float>(v[i]);
    bin_.lo[i] = std::fmin(bin_.lo[i], value);  // a NaN never hides a value
    bin_.hi[i] = std::fmax(bin_.hi[i], value);
    bin_.last[i] = value;
  }
  const bool changed = r.phase != live_.phase || r.safety != live_.safety;
  live_.phase = r.phase;
  live_.safety = r.safety;
  if (r.cause != TripCause::kNone && !tripped_) {
    tripped_ = true;
    trip_cause_ = r.cause;
    PublishTrip(r);
  }
  const auto now = std::chrono::steady_clock::now();
  if (changed || now - last_update_ >=
                     std::chrono::duration<double>(options_.update_seconds)) {
    last_update_ = now;
    PublishUpdate(changed);
  }
}

// As the loop's safety judges them: commanded force and its rate, travel
// and angles on the absolute pose, the error detector on the pose relative
// to the rest pose (after the tare), force tracking against the previous
// command, the watchdog on cycles without a fresh sample.
void LiveFeed::Margins(const CycleRecord& r, const double* v) {
  const SafetyLimits& l = run_.limits;
  for (int k = 0; k < 3; ++k) {
    live_.force[k] = Peak(live_.force[k], Fraction(v[k], l.force_max));
    if (have_command_) {
      const double rate = (v[k] - last_command_[k]) / run_.period;
      live_.rate[k] = Peak(live_.rate[k], Fraction(rate, l.force_rate_max));
      if (r.fresh && r.safety == SafetyState::kNormal) {
        live_.tracking[k] =
            Peak(live_.tracking[k],
                 Fraction(v[3 + k] - last_command_[k], l.force_error_max));
      }
    }
    last_command_[k] = v[k];
  }
  have_command_ = true;
  for (int k = 0; k < 6; ++k) {
    const bool angle = k >= 3;
    live_.limit[k] = Peak(live_.limit[k],
                          Fraction(r.y[k], angle ? l.angle_max : l.travel_max));
    if (r.phase != RunPhase::kTare) {
      live_.error[k] =
          Peak(live_.error[k],
               Fraction(v[6 + k] - v[12 + k],
                        angle ? l.error_angle_max : l.error_position_max));
    }
  }
  live_.watchdog =
      Peak(live_.watchdog, Fraction(static_cast<double>(not_fresh_),
                                    static_cast<double>(l.watchdog_cycles)));
}

// Bins waiting for the next update stay few: faster than real time,
// neighbours merge as they come (min of mins, max of maxes).
void LiveFeed::CloseBin() {
  unsent_.push_back(bin_);
  if (unsent_.size() < 2u * std::max(1, options_.max_bins_per_update)) return;
  std::vector<Bin> halved;
  for (std::size_t i = 0; i + 1 < unsent_.size(); i += 2) {
    halved.push_back(unsent_[i]);
    halved.back().Merge(unsent_[i + 1]);
  }
  if (unsent_.size() % 2 == 1) halved.push_back(unsent_.back());
  unsent_.swap(halved);
}

void LiveFeed::PublishTrip(const CycleRecord& record) {
  const Json doc = {
      {"cause", TripCauseName(record.cause)},
      {"message", LiveTripCause(record, run_.period)},
      {"t_s", static_cast<double>(record.cycle) * run_.period},
      {"seen_at_ms", std::chrono::duration<double, std::milli>(
                         std::chrono::system_clock::now().time_since_epoch())
                         .count()}};
  std::lock_guard<std::mutex> lock(mutex_);
  trip_json_ = Dump(doc);
  Publish("trip", trip_json_);
}

// The bins since the last update (merged down to max_bins_per_update) and
// the status; margins restart from the newest record.
void LiveFeed::PublishUpdate(bool with_open_bin) {
  std::vector<Bin> bins;
  bins.swap(unsent_);
  if (with_open_bin && bin_index_ >= 0) {
    // A phase or safety change shows at once, with the bin it falls in.
    bins.push_back(bin_);
    bin_index_ = -1;
  }
  const auto most =
      static_cast<std::size_t>(std::max(1, options_.max_bins_per_update));
  if (bins.size() > most) {
    const std::size_t group = (bins.size() + most - 1) / most;
    std::vector<Bin> merged;
    for (std::size_t i = 0; i < bins.size(); i += group) {
      Bin b = bins[i];
      for (std::size_t j = i + 1; j < std::min(bins.size(), i + group); ++j) {
        b.Merge(bins[j]);
      }
      merged.push_back(b);
    }
    bins.swap(merged);
  }
  std::string status = StatusJson();
  const std::string bins_json = bins.empty() ? "" : BinsJson(bins);
  live_.force = live_.rate = live_.tracking = {};
  live_.limit = live_.error = {};
  live_.watchdog = 0;
  std::lock_guard<std::mutex> lock(mutex_);
  if (!bins.empty()) {
    Publish("bins", bins_json);
    history_.insert(history_.end(), bins.begin(), bins.end());
    const auto cap = static_cast<std::size_t>(options_.history_bins);
    if (history_.size() > cap) {
      std::vector<Bin> halved;
      for (std::size_t i = 0; i < history_.size(); i += 2) {
        Bin b = history_[i];
        if (i + 1 < history_.size()) b.Merge(history_[i + 1]);
        halved.push_back(b);
      }
      history_.swap(halved);
    }
  }
  status_json_ = std::move(status);
  Publish("status", status_json_);
}

std::string LiveFeed::StatusJson() const {
  const Live& s = live_;
  Json doc = {{"t_s", s.t},
              {"phase", RunPhaseName(s.phase)},
              {"safety", SafetyName(s.safety)},
              // The loop holds the rig from activation to release; after
              // another master showed, it withholds its commands.
              {"owner", trip_cause_ == TripCause::kForeignMaster
                            ? "another master (this run withholds its commands)"
                            : "this run (" + run_.rig + ")"},
              {"margins",
               {{"force", Array(s.force.data(), 3)},
                {"force_rate", Array(s.rate.data(), 3)},
                {"force_tracking", Array(s.tracking.data(), 3)},
                {"limits", Array(s.limit.data(), 6)},
                {"error_detector", Array(s.error.data(), 6)},
                {"watchdog", s.watchdog}}},
              {"timing",
               {{"cycles", s.cycles},
                {"overruns", s.overruns},
                {"skipped_cycles", s.skipped},
                {"wakeup_p99_us", wakeup_.Percentile(0.99) * 1e-3},
                {"wakeup_max_us", wakeup_.max() * 1e-3}}}};
  return Dump(doc);
}

void LiveFeed::RunEnded(bool completed, const std::string& outcome,
                        const LoopResult& loop) {
  if (failed_) return;
  Guarded([&] {
    if (running_) PublishUpdate(true);
    const Json doc = {{"completed", completed},
                      {"outcome", outcome},
                      {"cycles", loop.cycles},
                      {"overruns", loop.overruns},
                      {"skipped_cycles", loop.skipped_cycles}};
    running_ = false;
    std::lock_guard<std::mutex> lock(mutex_);
    run_end_json_ = Dump(doc);
    Publish("run_end", run_end_json_);
  });
}

void LiveFeed::Title(const std::string& command) {
  Guarded([&] {
    std::lock_guard<std::mutex> lock(mutex_);
    title_json_ = Dump(Json{{"command", command}});
    Publish("title", title_json_);
  });
}

// Stages change with every batch of a design: at most one message per
// update interval; one held back is sent by FlushStage, and is always in
// the snapshot.
void LiveFeed::Stage(const std::string& text) {
  Guarded([&] {
    std::lock_guard<std::mutex> lock(mutex_);
    stage_json_ = Dump(Json(text));
    stage_pending_ = true;
    PublishStageIfDue();
  });
}

void LiveFeed::FlushStage() {
  Guarded([&] {
    std::lock_guard<std::mutex> lock(mutex_);
    PublishStageIfDue();
  });
}

void LiveFeed::PublishStageIfDue() {
  const auto now = std::chrono::steady_clock::now();
  if (!stage_pending_ || now - last_stage_ < std::chrono::duration<double>(
                                                 options_.update_seconds)) {
    return;
  }
  stage_pending_ = false;
  last_stage_ = now;
  Publish("stage", stage_json_);
}

void LiveFeed::Iteration(const std::string& entry_json) {
  Guarded([&] {
    const Json parsed = Json::parse(entry_json, nullptr, false);
    if (parsed.is_discarded()) return Note("an iteration could not be shown");
    const std::string doc = Dump(parsed);
    std::lock_guard<std::mutex> lock(mutex_);
    iterations_.push_back(doc);
    Publish("iteration", doc);
  });
}

void LiveFeed::ReportWritten(const std::string& path) {
  Guarded([&] {
    std::lock_guard<std::mutex> lock(mutex_);
    report_json_ = Dump(Json(path));
    Publish("report", report_json_);
  });
}

void LiveFeed::Note(const std::string& line) {
  Guarded([&] {
    std::lock_guard<std::mutex> lock(mutex_);
    const std::string doc = Dump(Json(line));
    // The newest few, for a late viewer.
    if (notes_.size() >= 20) notes_.erase(notes_.begin());
    notes_.push_back(doc);
    Publish("note", doc);
  });
}

void LiveFeed::End(const std::string& outcome) {
  Guarded([&] {
    std::lock_guard<std::mutex> lock(mutex_);
    if (ended_) return;
    end_json_ = Dump(Json(outcome));
    Publish("end", end_json_);
    ended_ = true;
  });
}

void LiveFeed::Fail(const char* what) {
  if (failed_.exchange(true)) return;
  if (options_.on_failure) {
    options_.on_failure(std::string("the console's feed stopped (") + what +
                        ")");
  }
}

std::string LiveFeed::BinsJson(const std::vector<Bin>& bins) {
  std::string out = "[";
  for (std::size_t b = 0; b < bins.size(); ++b) {
    if (b > 0) out += ',';
    out += '[';
    AppendNumber(bins[b].t0, &out);
    out += ',';
    AppendNumber(bins[b].t1, &out);
    for (const auto* values : {&bins[b].lo, &bins[b].hi, &bins[b].last}) {
      out += ",[";
      for (int i = 0; i < kSignals; ++i) {
        if (i > 0) out += ',';
        AppendNumber((*values)[i], &out);
      }
      out += ']';
    }
    out += ']';
  }
  return out + "]";
}

void LiveFeed::Publish(const char* event, std::string data) {
  if (ended_) return;
  std::string text = std::string("event: ") + event + "\ndata: ";
  text += data;
  text += "\n\n";
  log_bytes_ += text.size();
  log_.push_back({next_seq_++, std::move(text)});
  while (log_.size() > options_.max_messages ||
         (log_bytes_ > options_.max_log_bytes && log_.size() > 1)) {
    log_bytes_ -= log_.front().text.size();
    log_.pop_front();
  }
  changed_.notify_all();
}

// Copied under the lock, formatted outside it: the logger never waits for
// a viewer's snapshot.
std::string LiveFeed::Snapshot(std::uint64_t* seq) const {
  std::vector<Bin> history;
  std::string text = "event: snapshot\ndata: {";
  {
    std::lock_guard<std::mutex> lock(mutex_);
    history = history_;
    *seq = next_seq_ - 1;
    const auto list = [](const std::vector<std::string>& items) {
      std::string out = "[";
      for (std::size_t i = 0; i < items.size(); ++i) {
        out += (i > 0 ? "," : "") + items[i];
      }
      return out + "]";
    };
    text += "\"title\":" + title_json_ + ",\"run\":" + run_json_ +
            ",\"status\":" + status_json_ + ",\"trip\":" + trip_json_ +
            ",\"run_end\":" + run_end_json_ + ",\"stage\":" + stage_json_ +
            ",\"iterations\":" + list(iterations_) +
            ",\"report\":" + report_json_ + ",\"notes\":" + list(notes_) +
            ",\"end\":" + end_json_;
  }
  return text + ",\"history\":" + BinsJson(history) + "}\n\n";
}

LiveFeed::Read LiveFeed::ReadAfter(std::uint64_t* seq, std::string* out,
                                   std::chrono::milliseconds wait) const {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait_for(lock, wait, [&] { return next_seq_ - 1 > *seq || ended_; });
  if (!log_.empty() && log_.front().seq > *seq + 1) return Read::kStalled;
  const std::size_t start = out->size();
  for (const Message& m : log_) {
    if (m.seq <= *seq) continue;
    // A bounded copy per call: the rest comes with the next.
    if (out->size() - start >= kMaxReadBytes) return Read::kMessages;
    *out += m.text;
    *seq = m.seq;
  }
  return ended_ ? Read::kEnded : Read::kMessages;
}

std::size_t LiveFeed::held_bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::size_t bytes = log_bytes_ + history_.size() * sizeof(Bin);
  for (const std::string& it : iterations_) bytes += it.size();
  return bytes;
}

}  // namespace kcrig
