// The software-in-the-loop rig through the real rig session (loop, safety,
// phases, logger): deterministic for a seed, the plant's state carried from
// run to run, and each injected fault tripping at the cycle the safety
// rules say, every time.
#include "emulator/sil_rig.h"

#include <cmath>
#include <fstream>
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

constexpr std::int64_t kAt = 2000;  // in the settle phase, at -Fmax

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

}  // namespace
}  // namespace kcrig
