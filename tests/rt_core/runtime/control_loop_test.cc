// The real-time loop's logic with an in-memory rig (a RigPlant behind the
// RigInterface, no transport): phases and excitation, safety trips and the
// ramp-down, the watchdog, the signal path, and that a cycle never touches
// the heap (global operator new counts the loop thread's allocations).
#include "rt_core/runtime/control_loop.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <vector>

#include "gtest/gtest.h"
#include "rt_core/model/rig_plant.h"
#include "tests/support/allocation_counter.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

// A rig in memory: the true plant driven by the commands, one sample per
// read. Switches let a test silence it, or shift its readings.
class FakeRig : public RigInterface {
 public:
  explicit FakeRig(const KcrigConfig& config)
      : plant_(config.model, PlantEffects(), 1e-3) {
    plant_.Settle(Vec3<double>::Zero(), config.experiment.z_a);
  }
  Status Configure() override { return Status::Ok(); }
  Status Activate() override { return Status::Ok(); }
  Status Deactivate() override { return Status::Ok(); }
  void OnError() override {}
  IoResult Read(RigMeasurement* m) override {
    if (silent) return IoResult::kError;
    if (foreign) return IoResult::kForeign;
    if (counter_jumps_to != 0) sample_ = counter_jumps_to - 1;
    counter_jumps_to = 0;
    m->sample = ++sample_;
    sample_ += extra_samples;
    m->force = force_ + force_offset;
    m->y = plant_.pose() + offset;
    m->status = kRigEnabled;
    return IoResult::kFresh;
  }
  IoResult Write(const RigCommand& command) override {
    commands.push_back(command.force);  // reserved: no allocation
    enabled.push_back(command.enable);
    force_ = command.force;
    plant_.Step(force_ + force_offset);
    return IoResult::kFresh;
  }
  std::string Describe() const override { return "fake"; }
  std::string CountersJson() const override { return "{}"; }

  bool silent = false;
  bool foreign = false;                // reports another master in control
  std::uint32_t extra_samples = 0;     // taken after each read, for others
  std::uint32_t counter_jumps_to = 0;  // the next sample's number, once
  Vec3<double> force_offset = Vec3<double>::Zero();  // another master's push
  Vec6<double> offset = Vec6<double>::Zero();
  std::vector<Vec3<double>> commands;
  std::vector<bool> enabled;

 private:
  RigPlant plant_;
  Vec3<double> force_ = Vec3<double>::Zero();
  std::uint32_t sample_ = 0;
};

class ControlLoopTest : public ::testing::Test {
 protected:
  ControlLoopTest() : config_(SourceConfig()), rig_(config_), ring_(1 << 14) {
    options_.period = 1e-3;
    options_.excitation = {config_.experiment.phi, config_.experiment.z_a, 4000,
                           4.0};
    rig_.commands.reserve(20000);
    rig_.enabled.reserve(20000);
  }

  // Steps the loop without sleeping until it ends (or `cycles`); calls
  // `at(cycle)` before each cycle.
  std::int64_t Step(ControlLoop* loop, std::int64_t cycles,
                    const std::function<void(std::int64_t)>& at = nullptr) {
    std::int64_t k = 0;
    for (; k < cycles; ++k) {
      if (at) at(k);
      const bool go_on = loop->Cycle(k);
      CycleRecord record;
      while (ring_.Pop(&record)) records_.push_back(record);
      if (!go_on) return k + 1;
    }
    return k;
  }

  KcrigConfig config_;
  FakeRig rig_;
  SpscRing<CycleRecord> ring_;
  std::vector<CycleRecord> records_;
  LoopOptions options_;
  std::atomic<int> stop_{0};
};

TEST_F(ControlLoopTest, RunsTheWholeProfileAndTracksTheModel) {
  ControlLoop loop(config_.model, options_, &rig_, &ring_, &stop_);
  const RunProfile profile(options_.profile, options_.excitation);
  const std::int64_t cycles = Step(&loop, 100000);
  EXPECT_EQ(cycles, std::llround(profile.duration() / 1e-3));
  EXPECT_EQ(loop.result().cause, TripCause::kNone);
  EXPECT_EQ(loop.result().fresh, cycles);
  // Command = Fmax * level(t + period) along phi, ending at zero.
  const double ramp_mid = profile.ramp_start() + 3.0;  // level +0.5
  const int k = static_cast<int>(std::lround(ramp_mid / 1e-3));
  EXPECT_NEAR(rig_.commands[k].norm(), 4000 * 0.5, 3.0);
  EXPECT_NEAR(std::atan2(rig_.commands[k](1), rig_.commands[k](0)),
              options_.excitation.phi, 1e-9);
  EXPECT_LT(rig_.commands.back().norm(), 5.0);
  // The plant is the model here: the prediction follows the measurement.
  const CycleRecord& r = records_[k];
  EXPECT_NEAR(r.predicted[1], r.y[1], 5e-6);
  EXPECT_EQ(r.phase, RunPhase::kRamp);
}

TEST_F(ControlLoopTest, TravelLimitTripsAndRampsTheForceDownToDisabled) {
  options_.safety.travel_max = 0.0006;  // reached during the lead-in
  options_.safety.ramp_down_time = 0.25;
  ControlLoop loop(config_.model, options_, &rig_, &ring_, &stop_);
  Step(&loop, 100000);
  const LoopResult& result = loop.result();
  ASSERT_EQ(result.cause, TripCause::kTravelLimit);
  const std::int64_t trip = result.trip_cycle;
  // From the trip on: |F| falls linearly to zero over 250 cycles, then the
  // actuator is disabled and the loop ends.
  const double at_trip = rig_.commands[trip - 1].norm();
  EXPECT_GT(at_trip, 100);
  for (int j = 1; j <= 250; ++j) {
    EXPECT_NEAR(rig_.commands[trip + j - 1].norm(), at_trip * (1 - j / 250.0),
                1e-6 * at_trip)
        << j;
  }
  EXPECT_FALSE(rig_.enabled.back());
  EXPECT_EQ(static_cast<std::int64_t>(rig_.commands.size()), trip + 250);
  EXPECT_EQ(records_.back().safety, SafetyState::kDisabled);
}

TEST_F(ControlLoopTest, ErrorDetectorTripsWhenTheRigLeavesTheModel) {
  ControlLoop loop(config_.model, options_, &rig_, &ring_, &stop_);
  Step(&loop, 100000, [this](std::int64_t k) {
    if (k == 1500) rig_.offset(4) = 0.01;  // camber jumps by 0.57 deg
  });
  EXPECT_EQ(loop.result().cause, TripCause::kModelError);
  EXPECT_EQ(loop.result().trip_channel, 4);
  EXPECT_EQ(loop.result().trip_cycle, 1500);
}

// A second master (or a stuck valve) drives the rig: the load cell leaves
// this controller's command, and the loop trips after force_error_cycles.
TEST_F(ControlLoopTest, ForceTrackingTripsWhenTheRigDoesNotFollowTheCommand) {
  options_.safety.force_error_max = 500;
  options_.safety.force_error_cycles = 50;
  options_.safety.travel_max = 0.05;
  ControlLoop loop(config_.model, options_, &rig_, &ring_, &stop_);
  Step(&loop, 100000, [this](std::int64_t k) {
    // Just within the band for a while, then 1.5 kN in Fz.
    rig_.force_offset << 0, 0, k >= 2000 ? 1500 : k >= 1500 ? 450 : 0;
  });
  EXPECT_EQ(loop.result().cause, TripCause::kForceTracking);
  EXPECT_EQ(loop.result().trip_channel, 2);
  EXPECT_EQ(loop.result().trip_cycle, 2049);
  EXPECT_FALSE(rig_.enabled.back());
}

// The ramp-down runs on time: when overruns skip cycles, it still ends
// ramp_down_time after the trip instead of stretching over executed cycles.
TEST_F(ControlLoopTest, RampDownLastsItsTimeWhenCyclesAreSkipped) {
  options_.safety.travel_max = 0.0006;  // reached during the lead-in
  options_.safety.ramp_down_time = 0.25;
  ControlLoop loop(config_.model, options_, &rig_, &ring_, &stop_);
  std::int64_t cycle = 0;
  while (loop.Cycle(cycle, 0) && loop.result().cause == TripCause::kNone) {
    ++cycle;
  }
  const std::int64_t trip = loop.result().trip_cycle;
  ASSERT_EQ(loop.result().cause, TripCause::kTravelLimit);
  const double at_trip = rig_.commands[trip - 1].norm();
  const size_t first_ramp_command = rig_.commands.size() - 1;
  // Every later cycle comes three periods after the previous one.
  while (loop.Cycle(cycle += 3, 2)) {
    const double elapsed = (cycle - trip + 1) * 1e-3;
    EXPECT_NEAR(rig_.commands.back().norm(),
                at_trip * std::max(0.0, 1 - elapsed / 0.25), 1e-6 * at_trip);
  }
  EXPECT_GE(cycle - trip + 1, 250);
  EXPECT_LT(cycle - trip + 1, 253);
  EXPECT_LE(rig_.commands.size() - first_ramp_command, 85u);
  EXPECT_FALSE(rig_.enabled.back());
}

TEST_F(ControlLoopTest, WatchdogTripsAfterTheConfiguredSilentCycles) {
  options_.safety.watchdog_cycles = 20;
  ControlLoop loop(config_.model, options_, &rig_, &ring_, &stop_);
  Step(&loop, 100000, [this](std::int64_t k) { rig_.silent = k >= 1000; });
  EXPECT_EQ(loop.result().cause, TripCause::kWatchdog);
  EXPECT_EQ(loop.result().trip_cycle, 1019);
  EXPECT_EQ(loop.result().read_errors, loop.result().cycles - 1000);
  EXPECT_FALSE(rig_.enabled.back());
  EXPECT_EQ(rig_.commands.back(), Vec3<double>::Zero());
}

// Another master in control: the loop trips and sends nothing more (its
// ramp-down would fight the other master's commands); the rig's own limits
// and watchdog stop the rig.
TEST_F(ControlLoopTest, AForeignMasterTripsAndTheLoopStopsCommanding) {
  ControlLoop loop(config_.model, options_, &rig_, &ring_, &stop_);
  Step(&loop, 100000, [this](std::int64_t k) { rig_.foreign = k >= 1500; });
  EXPECT_EQ(loop.result().cause, TripCause::kForeignMaster);
  EXPECT_EQ(loop.result().trip_cycle, 1500);
  EXPECT_EQ(rig_.commands.size(), 1500u);
  EXPECT_EQ(loop.result().commands_after_trip, 0);
  EXPECT_EQ(loop.result().withheld_after_trip, loop.result().cycles - 1500);
}

TEST_F(ControlLoopTest, AStopSignalRampsDownLikeATrip) {
  ControlLoop loop(config_.model, options_, &rig_, &ring_, &stop_);
  Step(&loop, 100000, [this](std::int64_t k) {
    if (k == 2000) stop_ = 15;
  });
  EXPECT_EQ(loop.result().cause, TripCause::kSignal);
  EXPECT_EQ(loop.result().signal, 15);
  EXPECT_EQ(loop.result().trip_cycle, 2000);
  EXPECT_EQ(rig_.commands.back(), Vec3<double>::Zero());
}

// Either record of the run failing to reach the disk (the run log, or the
// transport's own: a CAN run's bus log) trips the loop and ramps down.
TEST_F(ControlLoopTest, ARecordThatCannotBeWrittenTripsTheRun) {
  for (int failing : {0, 1}) {
    std::atomic<bool> run_log{false}, bus_log{false};
    ControlLoop loop(config_.model, options_, &rig_, &ring_, &stop_);
    loop.add_log_failure(&run_log);
    loop.add_log_failure(&bus_log);
    Step(&loop, 100000, [&](std::int64_t k) {
      if (k == 1500) (failing == 0 ? run_log : bus_log) = true;
    });
    EXPECT_EQ(loop.result().cause, TripCause::kLogWrite) << failing;
    EXPECT_EQ(loop.result().trip_cycle, 1500) << failing;
    EXPECT_EQ(rig_.commands.back(), Vec3<double>::Zero());
    EXPECT_FALSE(rig_.enabled.back());
  }
}

TEST_F(ControlLoopTest, CommandsRespectForceAndRateLimits) {
  options_.excitation.fmax = 4000;
  options_.safety.force_max = 3000;
  options_.safety.force_rate_max = 3000;  // the lead-in wants 4000 N/s
  ControlLoop loop(config_.model, options_, &rig_, &ring_, &stop_);
  Step(&loop, 100000);
  EXPECT_EQ(loop.result().cause, TripCause::kNone);
  EXPECT_GT(loop.result().limited_commands, 0);
  for (size_t k = 1; k < rig_.commands.size(); ++k) {
    for (int a = 0; a < 3; ++a) {
      ASSERT_LE(std::abs(rig_.commands[k](a)), 3000.0);
      ASSERT_LE(std::abs(rig_.commands[k](a) - rig_.commands[k - 1](a)),
                3.0 + 1e-9);
    }
  }
}

// Lost samples are those the rig took for this controller and it never
// got; a counter that jumps (a restarted rig, a garbled or word-swapped
// counter) is counted apart and adds no loss.
TEST_F(ControlLoopTest, OnlySamplesTheRigTookAndTheLoopMissedCountAsLost) {
  ControlLoop loop(config_.model, options_, &rig_, &ring_, &stop_);
  Step(&loop, 3000, [&](std::int64_t k) {
    rig_.silent = k >= 100 && k < 105;      // 5 failed reads
    rig_.extra_samples = k == 200 ? 1 : 0;  // one sample read elsewhere
    if (k == 500) rig_.counter_jumps_to = 7000 * 65536u;  // word order
    if (k == 800) rig_.counter_jumps_to = 3;              // the rig restarted
  });
  EXPECT_EQ(loop.result().lost_rig_samples, 1);
  EXPECT_EQ(loop.result().rig_sample_jumps, 2);
}

TEST_F(ControlLoopTest, ACycleNeverAllocates) {
  options_.safety.ramp_down_time = 0.1;
  ControlLoop loop(config_.model, options_, &rig_, &ring_, &stop_);
  // Through every phase, a trip and the ramp-down.
  std::int64_t k = 0;
  bool go_on = true;
  long allocations = 0;
  {
    AllocationCounter counter;
    for (; go_on && k < 100000; ++k) {
      if (k == 5500) stop_ = 2;
      go_on = loop.Cycle(k);
      CycleRecord record;
      while (ring_.Pop(&record)) {
      }
    }
    allocations = counter.count();
  }
  EXPECT_EQ(loop.result().cause, TripCause::kSignal);
  EXPECT_GT(k, 5500);
  EXPECT_EQ(allocations, 0);
  // The counter works: an allocation on this thread is seen.
  AllocationCounter probe_counter;
  auto* probe = new std::vector<int>(3);
  EXPECT_GE(probe_counter.count(), 1);
  delete probe;
}

TEST(RunProfileTest, PhasesAndLevels) {
  RunProfileTimes times;  // 0.2, 1.0, 0.5, ramp, 1.0
  const RunProfile profile(times, {0.0, 0.0, 1.0, 4.0});
  EXPECT_DOUBLE_EQ(profile.duration(), 6.7);
  EXPECT_DOUBLE_EQ(profile.ramp_start(), 1.7);
  EXPECT_EQ(profile.Phase(0.1), RunPhase::kTare);
  EXPECT_EQ(profile.Level(0.1), 0.0);
  EXPECT_NEAR(profile.Level(0.7), -0.5, 1e-12);
  EXPECT_EQ(profile.Phase(1.5), RunPhase::kSettle);
  EXPECT_EQ(profile.Level(1.5), -1.0);
  EXPECT_NEAR(profile.Level(3.7), 0.0, 1e-12);
  EXPECT_EQ(profile.Phase(3.7), RunPhase::kRamp);
  EXPECT_NEAR(profile.Level(6.2), 0.5, 1e-12);
  EXPECT_EQ(profile.Phase(6.2), RunPhase::kRampDown);
  EXPECT_EQ(profile.Phase(6.8), RunPhase::kDone);
  EXPECT_EQ(profile.Level(6.8), 0.0);
}

TEST(RunProfileTest, HoldAndReturnRampRunBetweenRampAndRampDown) {
  RunProfileTimes times;  // 0.2, 1.0, 0.5, ramp 4, hold 0.5, return 2, 1.0
  const RunProfile profile(times, {0.0, 0.0, 1.0, 4.0, 0.5, 2.0});
  EXPECT_DOUBLE_EQ(profile.duration(), 9.2);
  EXPECT_EQ(profile.Phase(5.9), RunPhase::kHold);
  EXPECT_EQ(profile.Level(5.9), 1.0);
  EXPECT_EQ(profile.Phase(7.2), RunPhase::kReturn);
  EXPECT_NEAR(profile.Level(7.2), 0.0, 1e-12);
  EXPECT_EQ(profile.Phase(8.7), RunPhase::kRampDown);
  EXPECT_NEAR(profile.Level(8.7), -0.5, 1e-12);
  EXPECT_EQ(profile.Phase(9.3), RunPhase::kDone);
  // The same segments as the offline excitation, shifted by the ramp start.
  const RampExcitation<double> ramp{0.0, 0.0, 1.0, 4.0, 0.5, 2.0};
  EXPECT_DOUBLE_EQ(ramp.EndTime(), 6.5);
  for (double t = 0; t <= 6.5; t += 0.05) {
    EXPECT_NEAR(ramp.Profile(t), profile.Level(t + profile.ramp_start()), 1e-12)
        << t;
  }
}

TEST(CycleTimerTest, AnOverrunSkipsToTheNextDeadlineAhead) {
  // Exact counts would depend on preemption on a busy machine: check the
  // invariants instead (at least the passed deadlines are skipped, the
  // next cycle starts on a deadline after the overrunning work, indices and
  // counters agree).
  constexpr std::int64_t kPeriod = 2000000;  // 2 ms
  CycleTimer timer(kPeriod);
  timer.Start();
  CycleTimer::Wake wake = timer.WaitForNextCycle();
  EXPECT_EQ(wake.cycle, 0);
  EXPECT_EQ(wake.skipped, 0);
  const std::int64_t first_deadline = wake.deadline;
  std::int64_t skipped = 0;
  for (int round = 0; round < 2; ++round) {
    // Round 0 works 2.5 periods (deadlines 1 and 2 pass), round 1 just
    // past the next deadline.
    const std::int64_t work = round == 0 ? 5 * kPeriod / 2 : 11 * kPeriod / 10;
    const std::int64_t busy_until = wake.deadline + work;
    while (MonotonicNanoseconds() < busy_until) {
    }
    const std::int64_t previous = wake.cycle;
    const bool woke_in_time = wake.latency < kPeriod;
    const std::int64_t late_before = timer.skipped_by_late_wakeup();
    wake = timer.WaitForNextCycle();
    EXPECT_GE(wake.skipped, round == 0 ? 2 : 1);
    // Deadlines passed while working are the cycle's, not a late wake-up's.
    if (woke_in_time) {
      EXPECT_EQ(timer.skipped_by_late_wakeup(), late_before);
    }
    EXPECT_EQ(wake.cycle, previous + wake.skipped + 1);
    EXPECT_GE(wake.deadline, busy_until);  // not a deadline already passed
    // Still on the grid of deadlines: cycle k starts at first + k periods.
    EXPECT_EQ(wake.deadline - first_deadline, wake.cycle * kPeriod);
    skipped += wake.skipped;
  }
  EXPECT_EQ(timer.overruns(), 2);
  EXPECT_EQ(timer.skipped_cycles(), skipped);
  EXPECT_LE(timer.skipped_by_late_wakeup(), skipped);
}

TEST(CycleTimerTest, TheLastCycleIsNeverSkipped) {
  // Work past three deadlines after cycle 0 of a three-cycle run: cycle 1
  // is skipped, but the last one (2) runs, late, rather than none at all.
  constexpr std::int64_t kPeriod = 2000000;  // 2 ms
  CycleTimer timer(kPeriod, /*last_cycle=*/2);
  timer.Start();
  CycleTimer::Wake wake = timer.WaitForNextCycle();
  const std::int64_t busy_until = wake.deadline + 7 * kPeriod / 2;
  while (MonotonicNanoseconds() < busy_until) {
  }
  wake = timer.WaitForNextCycle();
  EXPECT_EQ(wake.cycle, 2);
  EXPECT_EQ(wake.skipped, 1);
  EXPECT_GE(wake.latency, kPeriod);  // its deadline had passed
  // The loop's own overrun is not the machine's wake-up latency.
  EXPECT_LT(wake.wakeup_latency, wake.latency);
  EXPECT_EQ(timer.skipped_cycles(), 1);
  // Past the last cycle (a trip's ramp-down goes on), deadlines are
  // skipped again.
  while (MonotonicNanoseconds() < wake.deadline + 5 * kPeriod / 2) {
  }
  wake = timer.WaitForNextCycle();
  EXPECT_GE(wake.cycle, 5);
  EXPECT_EQ(wake.skipped, wake.cycle - 3);
}

TEST(TimingStatisticsTest, PercentilesFromTheHistogram) {
  TimingStatistics s;
  for (int i = 1; i <= 1000; ++i) s.Record(i * 1000);  // 1 .. 1000 us
  EXPECT_EQ(s.count(), 1000);
  EXPECT_EQ(s.min(), 1000);
  EXPECT_EQ(s.max(), 1000000);
  EXPECT_NEAR(s.mean(), 500500, 1e-6);
  EXPECT_NEAR(s.Percentile(0.5), 500000, 100);
  EXPECT_NEAR(s.Percentile(0.99), 990000, 10000);
  EXPECT_EQ(s.Percentile(1.0), 1000000);
  s.Record(250000000);  // beyond the histogram: last bin, max exact
  EXPECT_EQ(s.max(), 250000000);
  EXPECT_EQ(s.Percentile(1.0), 250000000);
  std::int64_t total = 0;
  for (const auto& [lower, count] : s.Histogram()) total += count;
  EXPECT_EQ(total, 1001);
}

TEST(SpscRingTest, KeepsOrderAndCountsDropsWhenFull) {
  SpscRing<int> ring(4);
  for (int i = 0; i < 6; ++i) ring.Push(i);
  EXPECT_EQ(ring.dropped(), 2u);
  int value = -1;
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(ring.Pop(&value));
    EXPECT_EQ(value, i);
  }
  EXPECT_FALSE(ring.Pop(&value));
  // Across threads: every pushed value arrives once, in order.
  SpscRing<int> shared(64);
  std::thread producer([&] {
    for (int i = 0; i < 100000; ++i) {
      while (!shared.Push(i)) {
      }
    }
  });
  int expected = 0;
  while (expected < 100000) {
    if (shared.Pop(&value)) {
      ASSERT_EQ(value, expected++);
    }
  }
  producer.join();
}

}  // namespace
}  // namespace kcrig
