#include "records/timing_file.h"

#include <limits>

#include "base/json_reader.h"
#include "nlohmann/json.hpp"

namespace kcrig {
namespace {

using Json = nlohmann::ordered_json;

constexpr const char* kPhaseNames[] = {"wakeup", "read", "compute", "write",
                                       "cycle"};

Json PhaseJson(const TimingPhase& p) {
  Json histogram = Json::array();
  for (const auto& [lower, count] : p.histogram_us) {
    histogram.push_back({lower, count});
  }
  return {{"count", p.count},     {"min_us", p.min_us},
          {"mean_us", p.mean_us}, {"p50_us", p.p50_us},
          {"p99_us", p.p99_us},   {"p999_us", p.p999_us},
          {"max_us", p.max_us},   {"histogram_us", histogram}};
}

// A phase as written: p99, max and the histogram are required, the rest
// optional (NaN when absent).
Status ReadPhase(const nlohmann::json& node, const std::string& where,
                 TimingPhase* p) {
  for (Status s : {ReadField(node, "p99_us", where, &p->p99_us),
                   ReadField(node, "max_us", where, &p->max_us),
                   ReadField(node, "histogram_us", where, &p->histogram_us)}) {
    if (!s.ok()) return s;
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  p->count = node.value("count", std::int64_t{0});
  p->min_us = node.value("min_us", nan);
  p->mean_us = node.value("mean_us", nan);
  p->p50_us = node.value("p50_us", nan);
  p->p999_us = node.value("p999_us", nan);
  return Status::Ok();
}

Status ReadTimingDocument(const std::string& path, const nlohmann::json& doc,
                          TimingFile* t) {
  nlohmann::json phases;
  for (Status s : {ReadField(doc, "period_us", path, &t->period_us),
                   ReadField(doc, "phases", path, &phases)}) {
    if (!s.ok()) return s;
  }
  if (!phases.is_object()) {
    return Status::Error(path + ".phases: expected an object");
  }
  for (const auto& [name, node] : phases.items()) {
    KCRIG_RETURN_IF_ERROR(
        ReadPhase(node, path + ".phases." + name, &t->phases[name]));
  }
  t->cycles = doc.value("cycles", std::int64_t{0});
  t->overruns = doc.value("overruns", std::int64_t{0});
  t->skipped_cycles = doc.value("skipped_cycles", std::int64_t{0});
  t->skipped_by_late_wakeup =
      doc.value("skipped_by_late_wakeup", std::int64_t{0});
  t->dropped_log_records = doc.value("dropped_log_records", std::int64_t{0});
  const nlohmann::json realtime =
      doc.value("realtime", nlohmann::json::object());
  t->sched_fifo = realtime.value("sched_fifo", false);
  t->cpu_affinity = realtime.value("cpu_affinity", false);
  t->memory_locked = realtime.value("memory_locked", false);
  t->no_cpu_idle = realtime.value("no_cpu_idle", false);
  t->realtime_warnings = realtime.value("warnings", std::vector<std::string>());
  if (doc.contains("trip") && doc["trip"].is_string()) t->trip = doc["trip"];
  const nlohmann::json link = doc.value("link", nlohmann::json::object());
  if (!link.is_object()) {
    return Status::Error(path + ".link: expected an object");
  }
  t->read_errors = link.value("read_errors", std::int64_t{0});
  t->write_errors = link.value("write_errors", std::int64_t{0});
  t->stale_samples = link.value("stale_samples", std::int64_t{0});
  t->lost_rig_samples = link.value("lost_rig_samples", std::int64_t{0});
  if (link.contains("release_error") && link["release_error"].is_string()) {
    t->release_error = link["release_error"];
  }
  const nlohmann::json budget = doc.value("budget", nlohmann::json::object());
  if (!budget.is_object()) {
    return Status::Error(path +
                         ": unexpected content (budget: expected an "
                         "object)");
  }
  t->budget_checked = budget.contains("within");
  t->compute_p999_fraction = budget.value("compute_p999_fraction", 0.0);
  t->wakeup_p99_us = budget.value("wakeup_p99_us", 0.0);
  t->cycle_p999_fraction = budget.value("cycle_p999_fraction", 0.0);
  t->overrun_max_fraction = budget.value("overrun_max_fraction", 0.0);
  t->within_budget = budget.value("within", false);
  t->violations = budget.value("violations", std::vector<std::string>());
  return Status::Ok();
}

}  // namespace

std::string TimingFileToJson(const TimingFile& t) {
  Json doc;
  doc["format"] = "kcrig timing 1";
  doc["period_us"] = t.period_us;
  doc["cycles"] = t.cycles;
  doc["overruns"] = t.overruns;
  doc["skipped_cycles"] = t.skipped_cycles;
  doc["skipped_by_late_wakeup"] = t.skipped_by_late_wakeup;
  doc["dropped_log_records"] = t.dropped_log_records;
  doc["trip"] = t.trip.empty() ? Json(nullptr) : Json(t.trip);
  doc["link"] = {
      {"read_errors", t.read_errors},
      {"write_errors", t.write_errors},
      {"stale_samples", t.stale_samples},
      {"lost_rig_samples", t.lost_rig_samples},
      {"release_error",
       t.release_error.empty() ? Json(nullptr) : Json(t.release_error)}};
  doc["realtime"] = {{"sched_fifo", t.sched_fifo},
                     {"cpu_affinity", t.cpu_affinity},
                     {"memory_locked", t.memory_locked},
                     {"no_cpu_idle", t.no_cpu_idle},
                     {"warnings", t.realtime_warnings}};
  Json phases;
  for (const char* name : kPhaseNames) {
    const auto found = t.phases.find(name);
    if (found != t.phases.end()) phases[name] = PhaseJson(found->second);
  }
  doc["phases"] = phases;
  doc["budget"] = {{"compute_p999_fraction", t.compute_p999_fraction},
                   {"wakeup_p99_us", t.wakeup_p99_us},
                   {"cycle_p999_fraction", t.cycle_p999_fraction},
                   {"overrun_max_fraction", t.overrun_max_fraction},
                   {"within", t.within_budget},
                   {"violations", t.violations}};
  if (t.has_baseline) {
    const TimingBaseline& b = t.baseline;
    doc["baseline_wakeup"] = {
        {"method",
         "clock_nanosleep TIMER_ABSTIME loop without work, same priority and "
         "period (as cyclictest -m -i)"},
        {"duration_s", b.duration_s},
        {"sched_fifo", b.sched_fifo},
        {"count", b.wakeup.count},
        {"min_us", b.wakeup.min_us},
        {"mean_us", b.wakeup.mean_us},
        {"p50_us", b.wakeup.p50_us},
        {"p99_us", b.wakeup.p99_us},
        {"p999_us", b.wakeup.p999_us},
        {"max_us", b.wakeup.max_us},
        {"kcrig_to_baseline_p99", b.kcrig_to_baseline_p99}};
  }
  return doc.dump(2) + "\n";
}

Status ReadTimingFile(const std::string& path, TimingFile* timing) {
  *timing = TimingFile();
  nlohmann::json doc;
  KCRIG_RETURN_IF_ERROR(ReadJsonFile(path, &doc));
  return GuardedRead(path,
                     [&] { return ReadTimingDocument(path, doc, timing); });
}

}  // namespace kcrig
