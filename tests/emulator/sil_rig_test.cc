// The software-in-the-loop rig through the real rig session (loop, safety,
// phases, logger): deterministic for a seed, the plant's state carried from
// run to run, and each injected fault tripping at the cycle the safety
// rules say, every time.
#include "emulator/sil_rig.h"

#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "estimator/experiment.h"
#include "gtest/gtest.h"
#include "hil/rig_config.h"
#include "hil/rig_session.h"
#include "nlohmann/json.hpp"
#include "records/run_log.h"
#include "tests/support/temp_dir_test.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

class SilRigTest : public TempDirTest {
 protected:
  SilRigTest() : config_(SourceConfig()) {
    EXPECT_TRUE(LoadRigConfig(KCRIG_TEST_CONFIG_DIR, &rig_config_).ok());
    EXPECT_TRUE(
        LoadPlantConfig(KCRIG_TEST_CONFIG_DIR, config_.model, &plant_).ok());
    excitation_ = PaperInitialExcitation(config_.experiment);
  }

  // One run on `rig` into `folder`, with `faults` injected.
  RigSessionResult Run(SilRig* rig, const std::string& folder,
                       const std::vector<std::string>& faults = {}) {
    std::vector<InjectedFault> parsed(faults.size());
    for (size_t i = 0; i < faults.size(); ++i) {
      EXPECT_TRUE(ParseInjectedFault(faults[i], &parsed[i]).ok()) << faults[i];
    }
    auto link = rig->Connect(parsed);
    RigSessionOptions options;
    options.excitation = excitation_;
    options.log_dir = Path(folder);
    options.clock = rig->clock();
    const RunMetadata truth = rig->Truth();
    options.truth = &truth;
    RigSessionResult result;
    const Status status =
        RunRigSession(config_, rig_config_, link.get(), options, &result);
    EXPECT_TRUE(status.ok()) << status.message();
    return result;
  }

  std::string Read(const std::string& path) {
    std::ifstream in(Path(path), std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  }

  KcrigConfig config_;
  RigConfig rig_config_;
  PlantConfig plant_;
  RampExcitation<double> excitation_;
};

TEST_F(SilRigTest, RunsTheWholeProfileAsAHilRunAndTheSameSeedGivesTheSameLog) {
  SilRig first(config_, plant_);
  ASSERT_TRUE(first.Start().ok());
  const RigSessionResult result = Run(&first, "a");
  EXPECT_TRUE(result.completed) << result.trip_message;
  const RunProfile profile(rig_config_.profile, excitation_);
  const auto cycles = std::llround(profile.duration() / rig_config_.period);
  EXPECT_EQ(result.loop.cycles, cycles);
  EXPECT_EQ(result.loop.fresh, cycles);
  EXPECT_EQ(result.loop.overruns, 0);
  EXPECT_EQ(result.loop.dropped_records, 0u);
  RunLog log;
  ASSERT_TRUE(ReadRunLog(Path("a/run.csv"), &log).ok());
  EXPECT_TRUE(log.has_loop_columns);
  EXPECT_EQ(static_cast<long long>(log.samples.size()), cycles);
  EXPECT_EQ(log.samples.front().phase, "tare");
  EXPECT_EQ(log.samples.back().phase, "ramp_down");
  const nlohmann::json sidecar = nlohmann::json::parse(Read("a/run.json"));
  EXPECT_EQ(sidecar["transport"], "embedded SIL rig (virtual clock)");
  EXPECT_EQ(sidecar["truth"]["parameters"]["c_O2"], 4.4e6);
  EXPECT_EQ(sidecar["hil"]["transport"]["clock"], "virtual");

  SilRig second(config_, plant_);
  ASSERT_TRUE(second.Start().ok());
  Run(&second, "b");
  EXPECT_EQ(Read("a/run.csv"), Read("b/run.csv"));
  plant_.seed += 1;
  SilRig other_seed(config_, plant_);
  ASSERT_TRUE(other_seed.Start().ok());
  Run(&other_seed, "c");
  EXPECT_NE(Read("a/run.csv"), Read("c/run.csv"));
}

// A worn bushing keeps its Dahl force after a run: the next run's tare
// (rest pose) is not the fresh rig's.
TEST_F(SilRigTest, ThePlantRemembersTheLastRun) {
  ASSERT_TRUE(
      ParseEffect("hysteresis:force=300,at=bushing:O2", &plant_.effects).ok());
  plant_.noise = false;
  SilRig rig(config_, plant_);
  ASSERT_TRUE(rig.Start().ok());
  const RigSessionResult fresh = Run(&rig, "1");
  const RigSessionResult after = Run(&rig, "2");
  ASSERT_TRUE(fresh.completed && after.completed);
  const double shift_x = after.loop.rest_pose(0) - fresh.loop.rest_pose(0);
  EXPECT_GT(std::abs(shift_x), 10e-6)
      << "x tare moved " << shift_x * 1e6 << " um";
  // A plant that keeps no state starts the next run from the first's rest.
  PlantConfig forgetful = plant_;
  forgetful.keeps_state = false;
  SilRig fresh_each_run(config_, forgetful);
  ASSERT_TRUE(fresh_each_run.Start().ok());
  const Vec6<double> first = Run(&fresh_each_run, "5").loop.rest_pose;
  const Vec6<double> second = Run(&fresh_each_run, "6").loop.rest_pose;
  EXPECT_LT(std::abs(second(0) - first(0)), 2e-6);
  // Without the effect the rig returns to the same rest pose.
  PlantConfig elastic = plant_;
  elastic.effects = PlantEffects();
  SilRig clean(config_, elastic);
  ASSERT_TRUE(clean.Start().ok());
  const Vec6<double> r1 = Run(&clean, "3").loop.rest_pose;
  const Vec6<double> r2 = Run(&clean, "4").loop.rest_pose;
  EXPECT_LT(std::abs(r2(0) - r1(0)), 2e-6);
}

// The tare and lead-in rows start from what the rig kept of its last run:
// measured, logged, and left out of every fit and statistic.
TEST_F(SilRigTest, TheFitLeavesOutTheRowsThatRememberTheLastRun) {
  SilRig rig(config_, plant_);
  ASSERT_TRUE(rig.Start().ok());
  ASSERT_TRUE(Run(&rig, "r").completed);
  RunLog log;
  ASSERT_TRUE(ReadRunLog(Path("r/run.csv"), &log).ok());
  Experiment experiment;
  ASSERT_TRUE(
      MakeExperiment("run.csv", log, config_.experiment.step, &experiment)
          .ok());
  const auto memory =
      std::llround((rig_config_.profile.tare + rig_config_.profile.lead_in) /
                   rig_config_.period);
  EXPECT_EQ(experiment.memory_rows, memory);
  ASSERT_EQ(experiment.observed.size(), log.samples.size());
  EXPECT_FALSE(experiment.observed[memory - 1]);
  EXPECT_TRUE(experiment.observed[memory]);
  EXPECT_EQ(log.samples[memory].phase, "settle");
  EXPECT_EQ(ObservedCount(experiment),
            static_cast<int>(log.samples.size() - memory));

  // A run that ended in its lead-in has nothing the memory leaves alone.
  log.samples.resize(memory);
  const Status status =
      MakeExperiment("short.csv", log, config_.experiment.step, &experiment);
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.message().find("short.csv: fewer than two fresh rows "
                                  "after the tare and the lead-in"),
            std::string::npos)
      << status.message();
}

struct FaultCase {
  std::string fault;
  TripCause cause;
  // The trip's cycle after the fault's (-1: no trip).
  std::int64_t after;
};

class SilRigFaultTest : public SilRigTest,
                        public ::testing::WithParamInterface<FaultCase> {};

// 0.3 s into the ramp (tare 0.2, lead-in 1.0, settle 0.5 s), at -3.4 kN.
constexpr std::int64_t kAt = 2000;

TEST_P(SilRigFaultTest, TripsAtTheCycleTheSafetyRulesSay) {
  const FaultCase& c = GetParam();
  for (int repeat = 0; repeat < 2; ++repeat) {
    SilRig rig(config_, plant_);
    ASSERT_TRUE(rig.Start().ok());
    const RigSessionResult result =
        Run(&rig, "r" + std::to_string(repeat), {c.fault});
    EXPECT_EQ(TripCauseName(result.loop.cause), TripCauseName(c.cause))
        << c.fault << ": " << result.trip_message;
    if (c.after >= 0) {
      EXPECT_EQ(result.loop.trip_cycle, kAt + c.after) << c.fault;
      EXPECT_FALSE(result.completed);
    } else {
      EXPECT_TRUE(result.completed) << result.trip_message;
    }
  }
}

const int kWatchdog = 20;  // rig.yaml safety.watchdog_cycles

INSTANTIATE_TEST_SUITE_P(
    Faults, SilRigFaultTest,
    ::testing::Values(
        // A NaN never reaches the model: invalid measurement, that cycle.
        FaultCase{"nan:at=2000,channel=caster", TripCause::kInvalidMeasurement,
                  0},
        FaultCase{"nan:at=2000,channel=Fy", TripCause::kInvalidMeasurement, 0},
        // A garbled reply (x out of all range): travel limit, that cycle.
        FaultCase{"corrupt:at=2000", TripCause::kTravelLimit, 0},
        // No fresh sample for watchdog_cycles cycles in a row.
        FaultCase{"silent:at=2000", TripCause::kWatchdog, kWatchdog - 1},
        FaultCase{"stale:at=2000,cycles=20", TripCause::kWatchdog,
                  kWatchdog - 1},
        // Fewer than the watchdog's cycles: counted, no trip.
        FaultCase{"stale:at=2000,cycles=19", TripCause::kNone, -1},
        FaultCase{"lost:at=2000", TripCause::kNone, -1},
        // A reply 30 ms late: 30 cycles skipped, but the sample is fresh.
        FaultCase{"late:at=2000,delay=0.03", TripCause::kNone, -1},
        // 60 ms without a command: the rig's own 50 ms watchdog faults it,
        // which the late sample already reports.
        FaultCase{"late:at=2000,delay=0.06", TripCause::kRigFault, 0}),
    [](const ::testing::TestParamInfo<FaultCase>& info) {
      std::string name = info.param.fault.substr(0, info.param.fault.find(':'));
      return name + std::to_string(info.index);
    });

TEST_F(SilRigTest, CountsWhatItInjectedWithoutATrip) {
  SilRig rig(config_, plant_);
  ASSERT_TRUE(rig.Start().ok());
  const RigSessionResult result = Run(
      &rig, "r",
      {"lost:at=2000", "stale:at=3000,cycles=5", "late:at=4000,delay=0.03"});
  ASSERT_TRUE(result.completed) << result.trip_message;
  EXPECT_EQ(result.loop.read_errors, 1);
  EXPECT_EQ(result.loop.lost_rig_samples, 1);
  EXPECT_EQ(result.loop.stale, 5);
  EXPECT_EQ(result.loop.overruns, 1);
  EXPECT_EQ(result.loop.skipped_cycles, 30);
}

// A stuck sensor: the error detector trips on the first cycle whose
// measured - rest - predicted leaves the limit, as the log shows.
TEST_F(SilRigTest, AStuckSensorTripsWhenTheModelLeavesIt) {
  SilRig rig(config_, plant_);
  ASSERT_TRUE(rig.Start().ok());
  const RigSessionResult result = Run(&rig, "r", {"stuck:at=2000,channel=z"});
  ASSERT_EQ(result.loop.cause, TripCause::kModelError) << result.trip_message;
  EXPECT_EQ(result.loop.trip_channel, 2);
  RunLog log;
  ASSERT_TRUE(ReadRunLog(Path("r/run.csv"), &log).ok());
  const double rest = result.loop.rest_pose(2);
  std::int64_t first = -1;
  for (size_t i = 0; i < log.samples.size() && first < 0; ++i) {
    const LogSample& s = log.samples[i];
    if (std::abs(s.y(2) - rest - s.predicted(2)) >
        rig_config_.safety.error_position_max) {
      first = static_cast<std::int64_t>(i);
    }
  }
  EXPECT_GT(first, kAt);
  EXPECT_EQ(result.loop.trip_cycle, first);
}

TEST(InjectedFaultTest, RefusesWhatItCannotInject) {
  InjectedFault fault;
  for (const char* bad :
       {"", "wobble:at=1", "nan:at=1", "nan:at=1,channel=q", "late:at=1",
        "late:at=1,delay=-1", "late:at=1,delay=nan", "stale:at=1,cycles=0",
        "lost", "lost:at=-1", "lost:at=1.5", "lost:at=1,delay=2",
        "silent:at=1e12", "stuck:channel=z", "lost:at"}) {
    const Status status = ParseInjectedFault(bad, &fault);
    EXPECT_FALSE(status.ok()) << bad;
    EXPECT_EQ(status.message().find('\n'), std::string::npos);
  }
  ASSERT_TRUE(ParseInjectedFault("stale:at=7", &fault).ok());
  EXPECT_EQ(fault.cycles, 1);
  ASSERT_TRUE(ParseInjectedFault("nan:at=7,channel=Fz", &fault).ok());
  EXPECT_EQ(fault.channel, 8);
}

// The SIL link as the loop sees it, watched from the rig's side: after
// each read, the rig's true actuator force and status and the time; and
// the operator's stop pressed at a chosen read.
class WatchedLink final : public RigInterface {
 public:
  WatchedLink(std::unique_ptr<RigInterface> link, const SilRig& rig,
              std::atomic<int>* stop, std::int64_t stop_at)
      : link_(std::move(link)), rig_(rig), stop_(stop), stop_at_(stop_at) {
    force_.reserve(20000);
    status_.reserve(20000);
    time_.reserve(20000);
  }
  Status Configure() override { return link_->Configure(); }
  Status Activate() override { return link_->Activate(); }
  Status Deactivate() override { return link_->Deactivate(); }
  void OnError() override { link_->OnError(); }
  IoResult Read(RigMeasurement* m) override {
    if (static_cast<std::int64_t>(time_.size()) == stop_at_) *stop_ = SIGINT;
    const IoResult result = link_->Read(m);
    force_.push_back(rig_.emulator().actuator_force().cwiseAbs().maxCoeff());
    status_.push_back(rig_.emulator().status());
    time_.push_back(const_cast<SilRig&>(rig_).clock()->Seconds());
    return result;
  }
  IoResult Write(const RigCommand& command) override {
    return link_->Write(command);
  }
  std::string Describe() const override { return link_->Describe(); }
  std::string CountersJson() const override { return link_->CountersJson(); }

  std::vector<double> force_;  // the rig's largest axis force [N]
  std::vector<std::uint16_t> status_;
  std::vector<double> time_;  // [s]

 private:
  std::unique_ptr<RigInterface> link_;
  const SilRig& rig_;
  std::atomic<int>* stop_;
  std::int64_t stop_at_;
};

// One row of the fault-reaction matrix: latencies in cycles from the fault
// (-1: never within the run).
struct Reaction {
  std::string cause;       // the loop's trip cause, "none" without a trip
  std::int64_t trip = -1;  // the loop's first safe command (its trip)
  std::int64_t rig = -1;   // the rig faults itself
  std::int64_t low = -1;   // every axis of the rig's force < 5 % force_max
  std::int64_t off = -1;   // disabled: the loop's command, or the rig's own
                           // with its force under 1 N
  bool withheld = false;   // the loop sent nothing after its trip
};

class FaultReactionTest : public SilRigTest {
 protected:
  // A run with `inject` (or the operator's stop) at read kAt, or with the
  // fault at the loop's trip when `at_trip` (a limit reached).
  Reaction Measure(const std::string& inject, bool stop = false,
                   bool at_trip = false) {
    SilRig rig(config_, plant_);
    EXPECT_TRUE(rig.Start().ok());
    std::vector<InjectedFault> faults(inject.empty() ? 0 : 1);
    if (!inject.empty()) {
      EXPECT_TRUE(ParseInjectedFault(inject, &faults[0]).ok()) << inject;
    }
    std::atomic<int> signal{0};
    WatchedLink link(rig.Connect(faults), rig, &signal, stop ? kAt : -1);
    RigSessionOptions options;
    options.excitation = excitation_;
    options.log_dir = Path("r");
    options.clock = rig.clock();
    options.stop_signal = &signal;
    RigSessionResult result;
    EXPECT_TRUE(
        RunRigSession(config_, rig_config_, &link, options, &result).ok());
    Reaction r;
    r.cause = TripCauseName(result.loop.cause);
    r.withheld = result.loop.withheld_after_trip > 0;
    const double period = rig_config_.period;
    const std::int64_t at = at_trip ? result.loop.trip_cycle : kAt;
    if (at < 0 || at >= static_cast<std::int64_t>(link.time_.size())) {
      return r;
    }
    const double t0 = link.time_[at];
    auto cycles = [&](size_t i) {
      return std::llround((link.time_[i] - t0) / period);
    };
    if (result.loop.trip_cycle < 0) return r;  // no trip: nothing to time
    r.trip = result.loop.trip_cycle - at;
    const double low = 0.05 * rig_config_.safety.force_max;
    for (size_t i = at; i < link.time_.size(); ++i) {
      const bool faulted = link.status_[i] & kRigFault;
      const bool enabled = link.status_[i] & kRigEnabled;
      if (r.rig < 0 && faulted) r.rig = cycles(i);
      if (r.low < 0 && link.force_[i] < low) r.low = cycles(i);
      if (r.off < 0 && !enabled && link.force_[i] < 1.0) r.off = cycles(i);
    }
    // Else the loop's disable, at its last cycle, if it reached the rig.
    if (r.off < 0 && !r.withheld && result.loop.undelivered_after_trip == 0) {
      r.off = cycles(link.time_.size() - 1);
    }
    return r;
  }
};

std::string Cell(std::int64_t cycles) {
  return cycles < 0 ? "—" : std::to_string(cycles);
}

// The fault-reaction matrix of docs/rig.md, safety, on the SIL rig at 1 kHz:
// each fault at cycle 2000 (0.3 s into the ramp, at -3.4 kN), its reaction and
// latencies from the fault: to the loop's first safe command, to the rig's
// own fault, to every axis of the rig's force below 5 % of force_max, and
// to disabled (the loop's disable reaching the rig, or the rig's own at
// under 1 N). Printed as docs/rig.md's table; every latency within the
// bounds it states.
TEST_F(FaultReactionTest, EveryFaultsReactionIsMeasuredAndWithinItsBounds) {
  const struct {
    const char* fault;
    std::string inject;
    bool stop, at_trip;
    const char* reaction;
    const char* cause;  // the loop's trip, "none"
  } cases[] = {
      {"link lost (rig silent), controller killed", "silent:at=2000", false,
       false,
       "watchdog trip, ramp-down (undelivered); the rig's own "
       "watchdog faults and ramps down",
       "watchdog"},
      {"stale samples (20 reads)", "stale:at=2000,cycles=20", false, false,
       "watchdog trip, ramp-down, disable", "watchdog"},
      {"reply lost (one)", "lost:at=2000", false, false,
       "indicate (counted), no trip", "none"},
      {"late reply 30 ms (overrun)", "late:at=2000,delay=0.03", false, false,
       "indicate (overrun counted), no trip", "none"},
      {"late reply 60 ms (no command for 60 ms)", "late:at=2000,delay=0.06",
       false, false, "the rig's watchdog faults; rig_fault trip, ramp-down",
       "rig_fault"},
      {"corrupted reply", "corrupt:at=2000", false, false,
       "travel_limit trip, ramp-down, disable", "travel_limit"},
      {"sensor NaN (caster)", "nan:at=2000,channel=caster", false, false,
       "invalid_measurement trip, ramp-down, disable", "invalid_measurement"},
      {"sensor stuck (z)", "stuck:at=2000,channel=z", false, false,
       "error_detector trip once the model leaves it, ramp-down, disable",
       "error_detector"},
      {"limit reached (travel 0.5 mm)", "", false, true,
       "travel_limit trip, ramp-down, disable", "travel_limit"},
      {"foreign master", "foreign:at=2000", false, false,
       "foreign_master trip, commands withheld; the rig's watchdog faults "
       "and ramps down",
       "foreign_master"},
      {"rig-side fault (its e-stop)", "estop:at=2000", false, false,
       "the rig ramps down; rig_fault trip, ramp-down, disable", "rig_fault"},
      {"operator stop (SIGINT)", "", true, false,
       "signal trip, ramp-down, disable", "signal"},
  };
  const double ramp_down = rig_config_.safety.ramp_down_time / 1e-3;
  const double rig_timeout = plant_.command_timeout / 1e-3;
  const double rig_ramp = plant_.ramp_down_time / 1e-3;
  std::printf(
      "| fault | reaction | loop trips | rig faults | force < 5 %% | "
      "disabled |\n|---|---|---|---|---|---|\n");
  for (const auto& c : cases) {
    const RigConfig saved = rig_config_;
    if (c.at_trip) rig_config_.safety.travel_max = 5e-4;
    const Reaction r = Measure(c.inject, c.stop, c.at_trip);
    rig_config_ = saved;
    std::printf("| %s | %s | %s | %s | %s | %s |\n", c.fault, c.reaction,
                r.withheld ? (Cell(r.trip) + ", withheld").c_str()
                           : Cell(r.trip).c_str(),
                Cell(r.rig).c_str(), Cell(r.low).c_str(), Cell(r.off).c_str());
    EXPECT_EQ(r.cause, c.cause) << c.fault;
    EXPECT_EQ(r.withheld, r.cause == "foreign_master") << c.fault;
    if (r.cause == "none") continue;  // indicated: the run went on
    // The loop trips within its watchdog's count (a stuck sensor: within
    // a second, once the model leaves it).
    EXPECT_GE(r.trip, 0) << c.fault;
    EXPECT_LE(r.trip, c.inject.rfind("stuck", 0) == 0 ? 1000 : 20) << c.fault;
    // Force below 5 %: by the loop's ramp-down (its time, the actuator's
    // lag), or by the rig's own ramp after its watchdog.
    const double by_loop = r.trip + ramp_down;
    const double by_rig = rig_timeout + rig_ramp;
    EXPECT_GE(r.low, 0) << c.fault;
    EXPECT_LE(r.low, std::max(by_loop, by_rig) + 10) << c.fault;
    EXPECT_GE(r.off, 0) << c.fault;
    EXPECT_LE(r.off, std::max(by_loop, by_rig) + 60) << c.fault;
  }
}

}  // namespace
}  // namespace kcrig
