// The software rig as a controller sees it (transport-free: commands in,
// samples out, simulated time): the actuator follows the set-point through
// its lag and dead time, the rig protects itself, and every unmodelled
// effect changes the sampled response in its documented direction.
#include "emulator/rig_emulator.h"

#include <cmath>
#include <functional>
#include <vector>

#include "gtest/gtest.h"
#include "tests/support/edited_config.h"
#include "tests/support/temp_dir_test.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

constexpr double kPeriod = 1e-3;
constexpr int kLateral = 1;

// A command from the rig's one master (session 7, claimed on first use).
void Command(RigEmulator* rig, const RigCommand& command) {
  RigRequest request;
  request.command = command;
  request.ownership.has_session = true;
  request.ownership.session = 7;
  request.ownership.claim = true;
  request.ownership.enable = command.enable;
  EXPECT_TRUE(rig->Request(request));
}

struct Trace {
  std::vector<RigMeasurement> samples;  // one per ms
};

// Commands `force(t)` every millisecond for `duration` and samples once per
// millisecond, sensors noise-free.
Trace Drive(const char* effect, const std::function<double(double)>& force,
            double duration) {
  const KcrigConfig config = SourceConfig();
  PlantConfig plant;
  EXPECT_TRUE(
      LoadPlantConfig(KCRIG_TEST_CONFIG_DIR, config.model, &plant).ok());
  plant.noise = false;
  PlantEffects effects;
  if (effect != nullptr) {
    EXPECT_TRUE(ParseEffect(effect, &effects).ok());
  }
  RigEmulator rig(config, plant, effects);
  EXPECT_TRUE(rig.Start(0.0).ok());
  Trace trace;
  RigCommand command;
  command.enable = true;
  command.z_a = -0.45;
  const int cycles = static_cast<int>(std::lround(duration / kPeriod));
  for (int k = 0; k <= cycles; ++k) {
    const double t = k * kPeriod;
    rig.AdvanceTo(t);
    trace.samples.push_back(rig.TakeSample());
    command.force << 0, force(t), 0;
    ++command.sequence;
    Command(&rig, command);
  }
  return trace;
}

// 0 -> 4 kN lateral over 2 s, hold 1 s, back to 0 over 2 s, hold 1 s.
double UpHoldDown(double t) {
  if (t < 2) return 2000 * t;
  if (t < 3) return 4000;
  if (t < 5) return 4000 - 2000 * (t - 3);
  return 0;
}

double Y(const Trace& trace, double t) {
  return trace.samples[std::lround(t / kPeriod)].y(kLateral);
}

// The rig's own protection values have ranges a rig can honour: a typo
// must not become a ramp-down of days or a travel limit of kilometres.
class PlantConfigTest : public TempDirTest {};

// plant.yaml's optional effects list (every key known, read through the
// one reader).
TEST_F(PlantConfigTest, AnEffectsListLoads) {
  const KcrigConfig config = SourceConfig();
  const std::string dir = Path("effects");
  EditConfig(dir, "plant.yaml",
             "load_cell:", "effects: [\"rig_compliance:k=2e7\"]\nload_cell:");
  PlantConfig plant;
  const Status status = LoadPlantConfig(dir, config.model, &plant);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_TRUE(plant.effects.rig_compliance.enabled);
  EXPECT_EQ(plant.effects.rig_compliance.k, 2e7);
}

TEST_F(PlantConfigTest, SafetyValuesOutOfRangeNameFileLineAndKey) {
  const KcrigConfig config = SourceConfig();
  const struct {
    const char* from;
    const char* to;
    const char* message;
  } cases[] = {
      {"ramp_down_time: 0.2", "ramp_down_time: 1e6",
       "plant.yaml:37: rig.ramp_down_time: must be within [0.001, 10]"},
      {"travel_max: 0.06", "travel_max: 1e300",
       "rig.travel_max: must be within [0.0001, 0.5]"},
      {"command_timeout: 0.05", "command_timeout: 0",
       "rig.command_timeout: must be within [0.001, 1]"},
      {"force_max: 5000.0", "force_max: 5000.0\n  force_max: 1e9",
       "actuator.force_max: duplicate key (first at line"},
      {"sigma: 0.5 ", "sigma: 1e300 ",
       "load_cell.sigma: must be within [0, 1000]"},
      {"resolution: 0.1 ", "resolution: 1e300 ",
       "load_cell.resolution: must be within [0, 100]"},
      {"c_O1: 3.6e6", "c_O1: 4.9e-324",
       "plant.yaml:6: true_parameters.c_O1: must be within [1000, 1e+12] N/m"},
      {"command_timeout: 0.05", "command_timeout: 0.05\n  comand_timeout: 9",
       "rig.comand_timeout: unknown key (known here: "},
  };
  int index = 0;
  for (const auto& c : cases) {
    const std::string dir = Path("case" + std::to_string(index++));
    EditConfig(dir, "plant.yaml", c.from, c.to);
    PlantConfig plant;
    const Status status = LoadPlantConfig(dir, config.model, &plant);
    ASSERT_FALSE(status.ok()) << c.to;
    EXPECT_NE(status.message().find(c.message), std::string::npos)
        << status.message();
  }
}

TEST(RigEmulatorTest, TheLoadCellFollowsTheSetPointThroughLagAndDeadTime) {
  const Trace trace = Drive(nullptr, UpHoldDown, 6);
  // On the 2000 N/s ramp the actuator trails by tau + dead time = 7 ms
  // (plant.yaml) plus the one-cycle hold of the command.
  const double trail =
      (2000 * 1.0 - trace.samples[1000].force(kLateral)) / 2000;
  EXPECT_NEAR(trail, 0.008, 0.0015);
  EXPECT_NEAR(trace.samples[2900].force(kLateral), 4000, 1.0);
  EXPECT_TRUE(trace.samples[100].status & kRigEnabled);
  EXPECT_EQ(trace.samples.back().sample, trace.samples.size());
}

TEST(RigEmulatorTest, ASilentControllerFaultsTheRigAndItsForceRampsDown) {
  const KcrigConfig config = SourceConfig();
  PlantConfig plant;
  ASSERT_TRUE(
      LoadPlantConfig(KCRIG_TEST_CONFIG_DIR, config.model, &plant).ok());
  RigEmulator rig(config, plant, PlantEffects());
  ASSERT_TRUE(rig.Start(0.0).ok());
  RigCommand command;
  command.enable = true;
  command.force << 0, 1000, 0;
  Command(&rig, command);
  rig.AdvanceTo(0.04);  // within command_timeout (0.05 s)
  EXPECT_EQ(rig.fault(), kFaultNone);
  EXPECT_NEAR(rig.actuator_force()(kLateral), 1000, 5);
  rig.AdvanceTo(0.06);
  EXPECT_EQ(rig.fault(), kFaultCommandTimeout);
  EXPECT_TRUE(rig.status() & kRigFault);
  EXPECT_TRUE(rig.status() & kRigWatchdog);
  rig.AdvanceTo(0.4);  // ramp_down_time 0.2 s + lag
  EXPECT_LT(std::abs(rig.actuator_force()(kLateral)), 1.0);
}

// The rig's emergency stop: it ramps down from what the rig applies (a
// disabled rig applies nothing, whatever set-point an unclaimed write
// left), and no reset clears it until it is released at the rig; only the
// owner resets a fault.
TEST(RigEmulatorTest, AnEmergencyStopHoldsUntilReleasedAtTheRig) {
  const KcrigConfig config = SourceConfig();
  PlantConfig plant;
  ASSERT_TRUE(
      LoadPlantConfig(KCRIG_TEST_CONFIG_DIR, config.model, &plant).ok());
  RigEmulator rig(config, plant, PlantEffects());
  ASSERT_TRUE(rig.Start(0.0).ok());
  RigRequest anonymous;  // unclaimed, disabled, 5 kN: obeyed, harmless
  anonymous.command.force << 0, 5000, 0;
  anonymous.ownership.has_session = true;
  anonymous.ownership.session = 9;
  ASSERT_TRUE(rig.Request(anonymous));
  std::atomic<int> button{RigEmulator::kButtonStop};
  rig.WireEmergencyStop(&button);
  for (double t = 0.001; t < 0.3; t += 0.001) {
    rig.AdvanceTo(t);
    ASSERT_LT(rig.actuator_force().norm(), 1e-9) << t;
  }
  EXPECT_EQ(rig.fault(), kFaultEmergencyStop);
  // Reset by anyone, by the owner: still stopped while the button is in.
  anonymous.reset_fault = true;
  rig.Request(anonymous);
  EXPECT_EQ(rig.fault(), kFaultEmergencyStop);
  RigRequest owner;
  owner.reset_fault = true;
  owner.ownership.has_session = true;
  owner.ownership.session = 7;
  owner.ownership.claim = true;
  ASSERT_TRUE(rig.Request(owner));
  EXPECT_EQ(rig.fault(), kFaultEmergencyStop);
  // Released at the rig: the owner's reset clears it; an anonymous one
  // would not have.
  button = RigEmulator::kButtonRelease;
  rig.AdvanceTo(0.31);
  anonymous.ownership.session = 9;
  rig.Request(anonymous);
  EXPECT_EQ(rig.fault(), kFaultEmergencyStop);
  ASSERT_TRUE(rig.Request(owner));
  EXPECT_EQ(rig.fault(), kFaultNone);
}

// Each effect against the nominal rig under the same commands.
class RigEffectTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    nominal_ = new Trace(Drive(nullptr, UpHoldDown, 6));
    rising_ = Y(*nominal_, 1.0);  // rising at 2 kN: deflection grows with +y
    held_ = Y(*nominal_, 2.9);    // held at 4 kN
  }
  static void TearDownTestSuite() { delete nominal_; }
  static Trace* nominal_;
  static double rising_, held_;
};
Trace* RigEffectTest::nominal_ = nullptr;
double RigEffectTest::rising_ = 0;
double RigEffectTest::held_ = 0;

TEST_F(RigEffectTest, NominalDeflectsWithTheLoad) {
  EXPECT_GT(held_, rising_);
  EXPECT_GT(rising_, Y(*nominal_, 0.0));
}

TEST_F(RigEffectTest, BushingDampingLagsWhileMovingAndRelaxesWhenHeld) {
  const Trace damped = Drive("bushing_damping", UpHoldDown, 6);
  EXPECT_LT(Y(damped, 1.0), rising_ - 2e-6);
  EXPECT_NEAR(Y(damped, 2.9), held_, 0.05 * (rising_ - Y(damped, 1.0)));
}

TEST_F(RigEffectTest, HysteresisLagsAndStaysDeflectedAfterUnloading) {
  const Trace dahl = Drive("hysteresis", UpHoldDown, 6);
  EXPECT_LT(Y(dahl, 1.0), rising_ - 2e-6);
  EXPECT_GT(Y(dahl, 6.0) - Y(dahl, 0.0), 2e-6);
  EXPECT_LT(std::abs(Y(*nominal_, 6.0) - Y(*nominal_, 0.0)), 2e-7);
}

TEST_F(RigEffectTest, ProgressiveStiffnessDeflectsLessAndRelativelyLessAtMore) {
  const Trace cubic = Drive("progressive_stiffness", UpHoldDown, 6);
  const double base = Y(*nominal_, 0.0);
  EXPECT_LT((Y(cubic, 2.9) - base) / (held_ - base),
            (Y(cubic, 1.0) - base) / (rising_ - base));
  EXPECT_LT(Y(cubic, 2.9), held_ - 2e-6);
}

TEST_F(RigEffectTest, ActuatorLagPutsTheWheelWhereItWasTauPlusDeadTimeAgo) {
  const Trace lag = Drive("actuator_lag", UpHoldDown, 6);
  // The load cell reads the same; the wheel trails by 60 ms.
  EXPECT_NEAR(lag.samples[1000].force(kLateral),
              nominal_->samples[1000].force(kLateral), 1e-9);
  const double earlier = Y(*nominal_, 0.94);
  EXPECT_NEAR(Y(lag, 1.0), earlier, 0.1 * (rising_ - earlier));
}

TEST_F(RigEffectTest, RigComplianceAddsForceOverStiffness) {
  const Trace soft = Drive("rig_compliance:k=5e7", UpHoldDown, 6);
  EXPECT_NEAR(Y(soft, 2.9) - held_, soft.samples[2900].force(kLateral) / 5e7,
              2e-6);  // quantization 1 um
}

TEST_F(RigEffectTest, SensorOffsetScalesAndShiftsTheReadings) {
  const Trace offset = Drive("sensor_offset", UpHoldDown, 6);
  EXPECT_NEAR(Y(offset, 2.9), 1.03 * held_ - 1e-4, 2e-6);
}

// The rule of one master, alone (the Modbus test runs it through the
// server, the HIL test through real processes).
TEST(RigOwnershipTest, OneSessionAtATimeReleasedByRequestSilenceOrHangUp) {
  using Verdict = RigOwnership::Verdict;
  RigOwnership o;
  auto request = [](std::uint16_t session, bool claim, bool release,
                    bool enable, int connection = 1) {
    RigOwnership::Request r;
    r.has_session = true;
    r.session = session;
    r.claim = claim;
    r.release = release;
    r.enable = enable;
    r.connection = connection;
    return r;
  };
  // Unclaimed: a disabled command is harmless, an enable needs a claim,
  // and session 0 cannot claim.
  EXPECT_EQ(o.Decide(request(7, false, false, false), 0), Verdict::kObey);
  EXPECT_EQ(o.Decide(request(7, false, false, true), 0), Verdict::kRefuse);
  EXPECT_EQ(o.Decide(request(0, true, false, true), 0), Verdict::kRefuse);
  EXPECT_EQ(o.Decide(request(7, true, false, true), 0), Verdict::kObey);
  EXPECT_EQ(o.owner(), 7);
  // Claimed: only requests carrying the owner's session on the owner's
  // connection; the token on another connection is refused, and only the
  // owner's connection is told it.
  EXPECT_EQ(o.Decide(request(8, true, false, true, 2), 0.01), Verdict::kRefuse);
  RigOwnership::Request no_session = request(7, false, false, false, 1);
  no_session.has_session = false;
  EXPECT_EQ(o.Decide(no_session, 0.01), Verdict::kRefuse);
  EXPECT_EQ(o.Decide(request(7, false, false, true, 2), 0.02),
            Verdict::kRefuse);
  EXPECT_EQ(o.Decide(request(7, false, false, true, 1), 0.02), Verdict::kObey);
  EXPECT_EQ(o.refused(), 5);
  EXPECT_EQ(o.VisibleOwner(1), 7);
  EXPECT_EQ(o.VisibleOwner(2), kOwnerHidden);
  EXPECT_TRUE(o.IsOwnerConnection(1));
  EXPECT_FALSE(o.IsOwnerConnection(2));
  // A token claimed on a shared bus (no connections) is the owner's alone.
  RigOwnership bus;
  EXPECT_EQ(bus.Decide(request(5, true, false, true, -1), 0), Verdict::kObey);
  EXPECT_EQ(bus.Decide(request(5, false, false, true, -1), 0), Verdict::kObey);
  EXPECT_EQ(bus.VisibleOwner(-1), 5);
  EXPECT_FALSE(bus.IsOwnerConnection(-1));
  // The hidden owner's value is never a session.
  RigOwnership fresh;
  EXPECT_EQ(fresh.Decide(request(kOwnerHidden, true, false, true), 0),
            Verdict::kRefuse);
  // Released by request, then another session may claim.
  EXPECT_EQ(o.Decide(request(7, false, true, false), 0.03),
            Verdict::kObeyAndRelease);
  EXPECT_EQ(o.owner(), 0);
  EXPECT_EQ(o.Decide(request(8, true, false, true, 2), 0.04), Verdict::kObey);
  // Silence beyond the timeout ends the claim; so does the owner's hang-up
  // (only the connection it claimed on).
  EXPECT_FALSE(o.Expire(0.09, 0.05));
  EXPECT_TRUE(o.Expire(0.10, 0.05));
  EXPECT_EQ(o.Decide(request(9, true, false, true, 3), 0.2), Verdict::kObey);
  EXPECT_FALSE(o.ConnectionClosed(1));
  EXPECT_TRUE(o.ConnectionClosed(3));
  EXPECT_EQ(o.owner(), 0);
}

}  // namespace
}  // namespace kcrig
