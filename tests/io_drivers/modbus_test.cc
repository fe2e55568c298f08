// The Modbus transport in one process: kcrig's master (ModbusRig) against
// the emulator's libmodbus server on loopback, plus the register map and
// rig.yaml loaders. Runs under the sanitizers, the rig on a virtual clock
// there (RigTime).
#include <arpa/inet.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <pthread.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <ostream>
#include <sstream>
#include <string>
#include <thread>

#include "emulator/modbus_front_end.h"
#include "emulator/rig_emulator.h"
#include "gtest/gtest.h"
#include "hil/rig_config.h"
#include "io_drivers/modbus_registers.h"
#include "io_drivers/modbus_rig.h"
#include "io_drivers/modbus_server.h"
#include "rt_core/runtime/clock.h"
#include "tests/support/allocation_counter.h"
#include "tests/support/edited_config.h"
#include "tests/support/temp_dir_test.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

TEST(ModbusRegistersTest, Float32AndUint32InBothWordOrders) {
  std::uint16_t words[2];
  PutFloat32(1.0, true, words);
  EXPECT_EQ(words[0], 0x3F80);
  EXPECT_EQ(words[1], 0x0000);
  PutFloat32(1.0, false, words);
  EXPECT_EQ(words[0], 0x0000);
  EXPECT_EQ(words[1], 0x3F80);
  for (bool high_first : {true, false}) {
    PutFloat32(-1234.5, high_first, words);
    EXPECT_EQ(GetFloat32(words, high_first), -1234.5);
    PutUint32(0xDEADBEEF, high_first, words);
    EXPECT_EQ(GetUint32(words, high_first), 0xDEADBEEFu);
  }
}

class ModbusConfigTest : public TempDirTest {
 protected:
  // Per case a fresh copy of the source config with `from` -> `to` in
  // `name`; returns the edited file's path.
  std::string Edited(const std::string& name, const std::string& from,
                     const std::string& to) {
    std::filesystem::remove_all(dir_);
    EditConfig(dir_.string(), name, from, to);
    return Path(name);
  }
};

TEST_F(ModbusConfigTest, TheSourceMapIsTheDocumentedOne) {
  ModbusMap map;
  const Status status = LoadModbusMap(
      std::string(KCRIG_TEST_CONFIG_DIR) + "/modbus_map.yaml", &map);
  ASSERT_TRUE(status.ok()) << status.message();
  EXPECT_EQ(map.unit_id, 1);
  EXPECT_TRUE(map.high_word_first);
  EXPECT_EQ(map.setpoint[0], 2);
  EXPECT_EQ(map.z_a, 8);
  EXPECT_EQ(map.protocol, 5);
  EXPECT_EQ(map.y[5], 22);
  EXPECT_EQ(map.session, 10);
  EXPECT_EQ(map.owner, 24);
  EXPECT_EQ(map.refused_writes, 25);
  EXPECT_EQ(map.input_count(), 26);
  EXPECT_EQ(map.holding_count(), 11);
}

TEST_F(ModbusConfigTest, BadMapsAndRigConfigsNameFileLineAndKey) {
  const struct {
    const char* file;
    const char* from;
    const char* to;
    const char* message;
  } cases[] = {
      {"modbus_map.yaml", "  fy: 8", "  fy: 7",
       "input_registers.fy: overlaps fx"},
      {"modbus_map.yaml", "word_order: high_word_first", "word_order: middle",
       "word_order: must be high_word_first or low_word_first"},
      {"modbus_map.yaml", "unit_id: 1", "unit_id: 300",
       "unit_id: must be a whole number in [0, 247]"},
      {"modbus_map.yaml", "  sequence: 1", "  sequence: x",
       "holding_registers.sequence: expected a number"},
      {"rig.yaml", "response_timeout: 0.0004", "response_timeout: 0.0008",
       "modbus.response_timeout: must be <= half of loop.period"},
      {"rig.yaml", "parity: N", "parity: X",
       "modbus.rtu.parity: must be N, E or O"},
      {"rig.yaml", "ramp_down_time: 0.5", "ramp_down_time: 0.1",
       "safety.ramp_down_time: a trip at force_max"},
      // A ramp-down of 35 days would overflow and could not be stopped.
      {"rig.yaml", "ramp_down_time: 0.5", "ramp_down_time: 3e6",
       "safety.ramp_down_time: must be within [0.001, 10]"},
      {"rig.yaml", "force_rate_max: 20000.0", "force_rate_max: 1.0e6",
       "safety.force_error_max: must exceed force_rate_max x 2 cycles"},
      {"rig.yaml", "force_error_cycles: 50", "force_error_cycles: 5000",
       "safety.force_error_cycles: must be at most 1 s of cycles"},
      {"rig.yaml", "travel_max: 0.05", "travel_max: 1e300",
       "safety.travel_max: must be within [0.0001, 0.5]"},
      // yaml-cpp would read the first and ignore the second.
      {"rig.yaml", "  force_max: 5000.0",
       "  force_max: 5000.0\n  force_max: 9e3",
       "safety.force_max: duplicate key (first at line"},
      // A budget that always passes, a reconnect every 3e292 years, a
      // settle of no cycle; a misspelt safety key (a silent default).
      {"rig.yaml", "wakeup_p99: 0.0005", "wakeup_p99: 1e300",
       "timing_budget.wakeup_p99: must be within [1e-06, 1]"},
      {"rig.yaml", "reconnect_interval: 0.1", "reconnect_interval: 1e300",
       "modbus.reconnect_interval: must be within [0.01, 10]"},
      {"rig.yaml", "settle: 0.5", "settle: 1e-300",
       "run_profile.settle: must be 0 or within [loop.period, 60] s"},
      {"rig.yaml", "travel_max: 0.05", "travel_max: 0.05\n  travle_max: 0.01",
       "safety.travle_max: unknown key (known here: "},
      {"rig.yaml", "priority: 80", "priority: 120",
       "realtime.priority: must be a whole number in [0, 99]"},
      {"rig.yaml", "map: modbus_map.yaml", "map: [a, b]",
       "modbus.map: expected a text value"},
      {"rig.yaml", "safety:  ", "safety: 5\nsafety_old:  ",
       "safety: expected a mapping with 'force_max'"},
      {"modbus_map.yaml", "holding_registers:", "holding_registers: 3\nx:",
       "holding_registers: expected a mapping with 'control_word'"},
  };
  for (const auto& c : cases) {
    const std::string file = Edited(c.file, c.from, c.to);
    Status status;
    if (std::string(c.file) == "rig.yaml") {
      RigConfig rig;
      status = LoadRigConfig(dir_.string(), &rig);
    } else {
      ModbusMap map;
      status = LoadModbusMap(file, &map);
    }
    ASSERT_FALSE(status.ok()) << c.to;
    EXPECT_NE(status.message().find(file + ":"), std::string::npos)
        << status.message();
    EXPECT_NE(status.message().find(c.message), std::string::npos)
        << status.message();
  }
}

// The emulator's Modbus front end on a thread, on a free loopback port,
// keeping time by `clock`.
class InProcessRig {
 public:
  InProcessRig(const ModbusMap& map, const Clock& clock, int port = 0) {
    config_ = SourceConfig();
    EXPECT_TRUE(
        LoadPlantConfig(KCRIG_TEST_CONFIG_DIR, config_.model, &plant_).ok());
    emulator_ = std::make_unique<RigEmulator>(config_, plant_, PlantEffects());
    thread_ = std::thread([this, map, port, &clock] {
      ModbusServeAt at;
      at.host = "127.0.0.1";
      at.port = port;
      const Status status = ServeModbus(
          emulator_.get(), clock, map, at, stop_,
          [this](const std::string& uri) {
            port_ = std::stoi(uri.substr(uri.rfind(':') + 1));
          },
          [this](const std::string& line) {
            std::lock_guard<std::mutex> lock(notes_mutex_);
            notes_.push_back(line);
          });
      EXPECT_TRUE(status.ok()) << status.message();
    });
    while (port_ == 0)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ~InProcessRig() {
    stop_ = 1;
    thread_.join();
  }
  int port() const { return port_; }
  // What the server said of the connections it closed.
  std::string Notes() {
    std::lock_guard<std::mutex> lock(notes_mutex_);
    std::string all;
    for (const std::string& line : notes_) all += line + "\n";
    return all;
  }

 private:
  std::mutex notes_mutex_;
  std::vector<std::string> notes_;
  KcrigConfig config_;
  PlantConfig plant_;
  std::unique_ptr<RigEmulator> emulator_;
  std::atomic<int> stop_{0};
  std::atomic<int> port_{0};
  std::thread thread_;
};

// How the in-process rig keeps time. kVirtual: a clock the test advances by
// each period it waits, so the plant, the rig's command watchdog and its
// ownership timeout follow the test's cycles and no host (a loaded
// machine, the sanitizers' slowdown of the 10 kHz plant) can make the rig
// fall behind: the sanitizer tier runs these. kReal: the monotonic clock,
// as `kcrig emulate` runs, the test sleeping its periods: label
// ci-realtime, Release only, where a plant in real time is meaningful.
enum class RigTime { kVirtual, kReal };
void PrintTo(RigTime time, std::ostream* out) {
  *out << (time == RigTime::kReal ? "real" : "virtual");
}

class ModbusRigTest : public ::testing::TestWithParam<RigTime> {
 protected:
  ModbusRigTest() {
    EXPECT_TRUE(LoadRigConfig(KCRIG_TEST_CONFIG_DIR, &rig_config_).ok());
    EXPECT_TRUE(LoadModbusMap(rig_config_.modbus.map_file, &map_).ok());
    // Function, not timing (rt_bench measures that): a patient timeout so
    // that neither the sanitizers' slowdown nor a loaded machine (two
    // tests at once on two cores) turns replies into misses. The tests
    // about timing set their own.
    rig_config_.modbus.response_timeout = kPatientTimeout;
  }
  static constexpr double kPatientTimeout = 0.5;
  std::unique_ptr<ModbusRig> Master(int port) {
    ModbusEndpoint endpoint;
    EXPECT_TRUE(ParseModbusUri("modbus-tcp://127.0.0.1:" + std::to_string(port),
                               &endpoint)
                    .ok());
    return std::make_unique<ModbusRig>(endpoint, map_, rig_config_.modbus);
  }
  const Clock& rig_clock() const {
    if (GetParam() == RigTime::kReal) return real_clock_;
    return virtual_clock_;
  }
  // Lets `seconds` pass for the rig: sleeps on the real clock, advances the
  // virtual one.
  void Pass(double seconds) {
    if (GetParam() == RigTime::kReal) {
      std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    } else {
      virtual_clock_.Advance(std::llround(seconds * 1e9));
    }
  }
  RigConfig rig_config_;
  ModbusMap map_;
  MonotonicClock real_clock_;
  VirtualClock virtual_clock_;
};

TEST_P(ModbusRigTest, ReadsFreshSamplesAndWritesCommandsWithoutAllocating) {
  InProcessRig rig(map_, rig_clock());
  auto master = Master(rig.port());
  Status status = master->Configure();
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_TRUE(master->Activate().ok());
  RigMeasurement m;
  RigCommand command;
  command.enable = true;
  command.z_a = -0.45;
  long allocations = 0;
  int fresh = 0;
  std::uint32_t first_sample = 0;
  {
    AllocationCounter counter;
    for (int k = 0; k < 300; ++k) {
      command.force << 0, 2.0 * k, 0;  // 600 N at the end
      ++command.sequence;
      if (master->Read(&m) == IoResult::kFresh) {
        if (fresh++ == 0) first_sample = m.sample;
      }
      master->Write(command);
      Pass(500e-6);
    }
    allocations = counter.count();
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_GE(fresh, 270);  // a loaded machine may delay a few replies
  EXPECT_GE(m.sample - first_sample, static_cast<std::uint32_t>(fresh - 1));
  EXPECT_TRUE(m.status & kRigEnabled);
  // The load cell follows the set-point (5 ms lag + 2 ms dead time).
  EXPECT_NEAR(m.force(1), 600, 40);
  EXPECT_GT(m.y(1), 1e-5);
  EXPECT_TRUE(master->Deactivate().ok());
}

TEST_P(ModbusRigTest, AnExceptionIsAMissedSampleAndTheLinkStays) {
  // A rig whose input table is two registers short: every read of the
  // whole map draws "illegal data address".
  ModbusMap short_map = map_;
  short_map.y[5] = 20;
  short_map.y[4] = 18;
  short_map.y[3] = 16;
  short_map.y[2] = 14;
  short_map.y[1] = 12;
  short_map.y[0] = 10;
  short_map.force[2] = 8;
  short_map.force[1] = 6;
  short_map.force[0] = 4;
  short_map.sequence_echo = 3;
  short_map.protocol = 5;
  short_map.owner = 22;
  short_map.refused_writes = 23;
  ASSERT_LT(short_map.input_count(), map_.input_count());
  auto rig = std::make_unique<InProcessRig>(map_, rig_clock());
  const int port = rig->port();
  auto master = Master(port);
  ASSERT_TRUE(master->Configure().ok());
  // The rig restarts with the short table; the master reconnects and its
  // reads draw exceptions: each a quick kError, the link kept.
  rig.reset();
  rig = std::make_unique<InProcessRig>(short_map, rig_clock(), port);
  RigMeasurement m;
  for (int k = 0; k < 100 && master->reconnects() == 0; ++k) {
    master->Read(&m);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_EQ(master->reconnects(), 1);
  for (int k = 0; k < 20; ++k) {
    const auto start = std::chrono::steady_clock::now();
    EXPECT_EQ(master->Read(&m), IoResult::kError);
    EXPECT_LT(std::chrono::steady_clock::now() - start,
              std::chrono::milliseconds(250));  // an answer, not a timeout
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(master->reconnects(), 1);  // never dropped for an exception
  // And a fresh master names the problem when it configures.
  auto second = Master(port);
  const Status status = second->Configure();
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.message().find("Illegal data address"), std::string::npos)
      << status.message();
}

TEST_P(ModbusRigTest, ALostLinkFailsFastAndIsReopenedOutsideTheCycle) {
  int port = 0;
  auto rig = std::make_unique<InProcessRig>(map_, rig_clock());
  port = rig->port();
  auto master = Master(port);
  ASSERT_TRUE(master->Configure().ok());
  RigMeasurement m;
  EXPECT_EQ(master->Read(&m), IoResult::kFresh);
  rig.reset();  // the server goes away
  // Every read fails at once (the closed connection is seen, not waited
  // out): it never blocks the cycle for the timeout.
  int errors = 0;
  for (int k = 0; k < 50; ++k) {
    const auto start = std::chrono::steady_clock::now();
    errors += master->Read(&m) == IoResult::kError;
    const auto took = std::chrono::steady_clock::now() - start;
    EXPECT_LT(took, std::chrono::milliseconds(250));
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_EQ(errors, 50);
  // The rig comes back on the same port: the background thread reconnects.
  rig = std::make_unique<InProcessRig>(map_, rig_clock(), port);
  IoResult result = IoResult::kError;
  for (int k = 0; k < 100 && result != IoResult::kFresh; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    result = master->Read(&m);
  }
  EXPECT_EQ(result, IoResult::kFresh);
  EXPECT_GE(master->reconnects(), 1);
}

// A raw TCP connection to the rig on loopback (its file descriptor).
int ConnectRaw(int port) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  EXPECT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)),
            0);
  return fd;
}

// A second Modbus client as any tool would be (libmodbus, no session
// logic): what a careless operator's program sends.
class OtherClient {
 public:
  explicit OtherClient(int port) {
    context_ = modbus_new_tcp("127.0.0.1", port);
    modbus_set_slave(context_, 1);
    modbus_set_response_timeout(context_, 1, 0);
    EXPECT_EQ(modbus_connect(context_), 0);
  }
  ~OtherClient() {
    modbus_close(context_);
    modbus_free(context_);
  }
  // Writes `words` from register 0; returns errno on failure, else 0.
  int Write(const std::vector<std::uint16_t>& words) {
    const int n = static_cast<int>(words.size());
    return modbus_write_registers(context_, 0, n, words.data()) == n ? 0
                                                                     : errno;
  }
  int WriteControlWord(std::uint16_t value) {
    return modbus_write_register(context_, 0, value) == 1 ? 0 : errno;
  }
  std::uint16_t Input(int address) {
    std::uint16_t value = 0xffff;
    EXPECT_EQ(modbus_read_input_registers(context_, address, 1, &value), 1);
    return value;
  }
  std::uint16_t Holding(int address) {
    std::uint16_t value = 0;
    EXPECT_EQ(modbus_read_registers(context_, address, 1, &value), 1);
    return value;
  }

 private:
  modbus_t* context_;
};

// Holding registers 0..10: control word, sequence, Fx, Fy, Fz = `fz`,
// z_a = -0.45 m, session.
std::vector<std::uint16_t> Command(std::uint16_t control, double fz,
                                   std::uint16_t session) {
  std::vector<std::uint16_t> words(11, 0);
  words[0] = control;
  words[1] = 7;
  PutFloat32(fz, true, &words[6]);
  PutFloat32(-0.45, true, &words[8]);
  words[10] = session;
  return words;
}

TEST_P(ModbusRigTest, TheRigObeysOneMasterAtATime) {
  InProcessRig rig(map_, rig_clock());
  auto owner = Master(rig.port());
  auto late = Master(rig.port());
  ASSERT_TRUE(owner->Configure().ok());
  ASSERT_TRUE(late->Configure().ok());  // the rig is still unclaimed
  ASSERT_TRUE(owner->Activate().ok());
  OtherClient other(rig.port());
  // Only the owner's connection is told its token.
  EXPECT_EQ(other.Input(map_.owner), kOwnerHidden);
  EXPECT_EQ(other.Holding(map_.session), kOwnerHidden);
  // A second kcrig is refused: when it connects, or at activation if it
  // connected before the claim.
  for (const Status& refused :
       {Master(rig.port())->Configure(), late->Activate()}) {
    ASSERT_FALSE(refused.ok());
    EXPECT_NE(refused.message().find("is in control (another master)"),
              std::string::npos)
        << refused.message();
  }
  late.reset();
  // Any other write, with or without a session or a claim, is refused
  // with "server busy" and counted; nothing of it reaches the rig. The
  // owner's own token is worth nothing on another connection.
  const std::uint16_t before = other.Input(map_.refused_writes);
  const std::uint16_t intruder = owner->session() ^ 0x5a5a;
  EXPECT_EQ(other.Write(Command(kControlEnable, 3000, intruder)), EMBXSBUSY);
  EXPECT_EQ(other.Write(Command(kControlEnable, 3000, owner->session())),
            EMBXSBUSY);
  EXPECT_EQ(other.Write(Command(kControlEnable | kControlClaim, 3000, 0)),
            EMBXSBUSY);
  std::vector<std::uint16_t> without_session = Command(kControlEnable, 3000, 0);
  without_session.resize(10);
  EXPECT_EQ(other.Write(without_session), EMBXSBUSY);
  EXPECT_EQ(other.WriteControlWord(0), EMBXSBUSY);
  EXPECT_EQ(
      static_cast<std::uint16_t>(other.Input(map_.refused_writes) - before), 5);
  RigMeasurement m;
  RigCommand command;
  command.enable = true;
  for (int k = 0; k < 20; ++k) {
    command.sequence = static_cast<std::uint16_t>(100 + k);
    const IoResult read = owner->Read(&m);
    EXPECT_TRUE(read == IoResult::kFresh || read == IoResult::kStale);
    owner->Write(command);
    Pass(1e-3);
  }
  EXPECT_LT(std::abs(m.force(2)), 50);
  // The owner learns of the refusals (run.json's transport counters): the
  // five, and the late master's claim.
  EXPECT_NE(owner->CountersJson().find("\"refused_writes\": 6"),
            std::string::npos)
      << owner->CountersJson();
  // Released: nobody enables the rig without a claim; a claim takes it.
  ASSERT_TRUE(owner->Deactivate().ok());
  EXPECT_EQ(other.Input(map_.owner), 0);
  EXPECT_EQ(other.Write(Command(kControlEnable, 0, intruder)), EMBXSBUSY);
  EXPECT_EQ(other.Input(map_.status) & kRigEnabled, 0);
  EXPECT_EQ(other.Write(Command(kControlEnable | kControlClaim, 0, intruder)),
            0);
  EXPECT_EQ(other.Input(map_.owner), intruder);
  // The old owner now reads another master in control: foreign.
  EXPECT_EQ(owner->Read(&m), IoResult::kForeign);
  EXPECT_NE(owner->CountersJson().find("obeys another master"),
            std::string::npos);
}

// A stall longer than the rig's command timeout (50 ms) but shorter than
// its claim timeout (1 s): the rig faults itself and ramps down, names its
// watchdog, and keeps the claim, so the controller's ramp-down and release
// still reach it and nothing blames a second master.
TEST_P(ModbusRigTest, AStallFaultsTheRigButLeavesTheClaimWithItsOwner) {
  InProcessRig rig(map_, rig_clock());
  auto owner = Master(rig.port());
  ASSERT_TRUE(owner->Configure().ok());
  ASSERT_TRUE(owner->Activate().ok());
  RigMeasurement m;
  RigCommand command;
  command.enable = true;
  command.force << 0, 0, 1000;
  for (int k = 0; k < 50; ++k) {
    command.sequence = static_cast<std::uint16_t>(k);
    owner->Read(&m);
    owner->Write(command);
    Pass(1e-3);
  }
  Pass(0.12);  // the stall
  IoResult read = IoResult::kStale;
  for (int k = 0; k < 5 && read != IoResult::kFresh; ++k)
    read = owner->Read(&m);
  ASSERT_EQ(read, IoResult::kFresh);
  EXPECT_NE(m.status & kRigFault, 0);
  EXPECT_NE(m.status & kRigWatchdog, 0);
  EXPECT_EQ(m.fault_code, kFaultCommandTimeout);
  command.sequence = 60;
  EXPECT_EQ(owner->Write(command), IoResult::kFresh);  // still obeyed
  const Status released = owner->Deactivate();
  EXPECT_TRUE(released.ok()) << released.message();
}

TEST_P(ModbusRigTest, TheOwnersConnectionClosingFaultsTheRigAndEndsTheClaim) {
  InProcessRig rig(map_, rig_clock());
  OtherClient observer(rig.port());
  {
    auto owner = Master(rig.port());
    ASSERT_TRUE(owner->Configure().ok());
    ASSERT_TRUE(owner->Activate().ok());
    EXPECT_EQ(observer.Input(map_.owner), kOwnerHidden);
  }  // the connection closes with the rig enabled
  for (int k = 0; k < 200 && observer.Input(map_.owner) != 0; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(observer.Input(map_.owner), 0);
  EXPECT_EQ(observer.Input(map_.fault_code), kFaultOwnerLost);
  EXPECT_NE(observer.Input(map_.status) & kRigFault, 0);
  // A new claim resets the fault (the force is down) and takes the rig.
  auto next = Master(rig.port());
  ASSERT_TRUE(next->Configure().ok());
  const Status status = next->Activate();
  EXPECT_TRUE(status.ok()) << status.message();
}

// A read longer than modbus.response_timeout that still returns a sample is
// one this thread collected late (libmodbus bounds the whole reply by the
// timeout): counted as a late reply, with its time. The thread is held off
// its wait by a signal handler that runs 120 ms, as a preemption or a VM's
// stolen time would hold it, while the rig answers within the 50 ms
// timeout (ten times what the rig needs even under the sanitizers on a
// loaded machine; 5 ms missed replies there).
void SpinLongerThanTheTimeout(int) {
  const auto end =
      std::chrono::steady_clock::now() + std::chrono::milliseconds(120);
  while (std::chrono::steady_clock::now() < end) {
  }
}

TEST_P(ModbusRigTest, AReplyCollectedLateIsCountedAsLate) {
  rig_config_.modbus.response_timeout = 0.05;
  InProcessRig rig(map_, rig_clock());
  auto master = Master(rig.port());
  ASSERT_TRUE(master->Configure().ok());
  auto late_replies = [&] {
    const std::string counters = master->CountersJson();
    const size_t at = counters.find("\"late_replies\": ");
    EXPECT_NE(at, std::string::npos) << counters;
    return at == std::string::npos ? -1 : std::stoi(counters.substr(at + 16));
  };
  // Unheld reads: only those that took longer than the timeout here (a
  // loaded machine can delay one) may count as late.
  RigMeasurement m;
  int slow_reads = 0;
  for (int k = 0; k < 20; ++k) {
    const auto start = std::chrono::steady_clock::now();
    ASSERT_NE(master->Read(&m), IoResult::kError);
    slow_reads += std::chrono::steady_clock::now() - start >=
                  std::chrono::milliseconds(50);
  }
  const int unheld_late = late_replies();
  EXPECT_LE(unheld_late, slow_reads);

  struct sigaction spin {};
  spin.sa_handler = SpinLongerThanTheTimeout;
  spin.sa_flags = SA_RESTART;
  struct sigaction previous {};
  ASSERT_EQ(sigaction(SIGUSR1, &spin, &previous), 0);
  const pthread_t reader = pthread_self();
  std::atomic<bool> done{false};
  std::thread holder([&] {
    while (!done.load()) {
      pthread_kill(reader, SIGUSR1);
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
  });
  // Back-to-back reads for 1.2 s: most of the six holds fall inside one.
  int reads = 0, answered = 0;
  const auto end =
      std::chrono::steady_clock::now() + std::chrono::milliseconds(1200);
  while (std::chrono::steady_clock::now() < end) {
    ++reads;
    answered += master->Read(&m) != IoResult::kError;
  }
  done = true;
  holder.join();
  sigaction(SIGUSR1, &previous, nullptr);
  EXPECT_GE(answered, reads - 2);  // held, not timed out
  const std::string counters = master->CountersJson();
  EXPECT_GE(late_replies() - unheld_late, 3) << counters;
  const size_t max_at = counters.find("\"late_reply_max_ms\": ");
  ASSERT_NE(max_at, std::string::npos) << counters;
  EXPECT_GE(std::stod(counters.substr(max_at + 21)), 100.0) << counters;
}

// Raw TCP clients that misbehave: half a frame, a byte at a time, garbage,
// more connections than the rig serves. None of them may delay the master.
TEST_P(ModbusRigTest, MisbehavingClientsDoNotStallTheRig) {
  InProcessRig rig(map_, rig_clock());
  auto master = Master(rig.port());
  ASSERT_TRUE(master->Configure().ok());
  auto connect_raw = [&] { return ConnectRaw(rig.port()); };
  const int partial = connect_raw();
  const std::uint8_t header[3] = {0, 1, 0};
  ASSERT_EQ(send(partial, header, 3, 0), 3);
  const int dribble = connect_raw();
  const int garbage = connect_raw();
  const char http[] = "GET / HTTP/1.1\r\n\r\n";
  ASSERT_GT(send(garbage, http, sizeof(http) - 1, 0), 0);
  std::vector<int> crowd;
  for (int k = 0; k < ModbusServer::kMaxClients + 4; ++k) {
    crowd.push_back(connect_raw());
  }
  RigMeasurement m;
  int answered = 0;
  double slowest = 0;
  const std::uint8_t frame[12] = {0, 2, 0, 0, 0, 6, 1, 4, 0, 0, 0, 26};
  for (int k = 0; k < 300; ++k) {
    // A byte every 20 cycles: a frame every 240, within the 0.5 s allowed.
    if (k % 20 == 0) send(dribble, &frame[(k / 20) % 12], 1, MSG_NOSIGNAL);
    const auto start = std::chrono::steady_clock::now();
    const IoResult read = master->Read(&m);
    slowest = std::max(slowest, std::chrono::duration<double>(
                                    std::chrono::steady_clock::now() - start)
                                    .count());
    answered += read != IoResult::kError;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  // A rig that waited out a half frame (0.5 s) would hold a read that long.
  EXPECT_EQ(answered, 300);
  EXPECT_LT(slowest, 0.2);
  // The garbage and the connections beyond the cap were closed (a reset
  // when the rig closed with bytes unread).
  auto closed_by_rig = [](int fd, double seconds) {
    timeval wait{0, static_cast<long>(seconds * 1e6)};
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &wait, sizeof(wait));
    char byte;
    const ssize_t n = recv(fd, &byte, 1, 0);
    return n == 0 || (n < 0 && errno == ECONNRESET);
  };
  EXPECT_TRUE(closed_by_rig(garbage, 0.5));
  int closed = 0;
  for (int fd : crowd) {
    closed += closed_by_rig(fd, 0.1);
    close(fd);
  }
  EXPECT_GE(closed, 4);
  // The half frame was dropped after its timeout.
  EXPECT_TRUE(closed_by_rig(partial, 0.9));
  close(partial);
  close(dribble);
  close(garbage);
}

// Connections opened and left idle (a crashed HMI, a port scan, an
// attacker) take the places the rig serves; once they have been idle a
// while, the master still gets in, runs, and holds its place against a
// flood of new ones, and the rig says what it closed.
TEST_P(ModbusRigTest, IdleConnectionsDoNotLockTheMasterOut) {
  for (const int idle_count : {16, 200}) {
    InProcessRig rig(map_, rig_clock());
    std::vector<int> idle;
    for (int k = 0; k < idle_count; ++k) idle.push_back(ConnectRaw(rig.port()));
    // Idle for longer than the 1 s a place is held (counted from the
    // server's accept: a margin for a loaded machine).
    std::this_thread::sleep_for(std::chrono::milliseconds(1600));
    auto master = Master(rig.port());
    const Status configured = master->Configure();
    ASSERT_TRUE(configured.ok()) << idle_count << ": " << configured.message();
    ASSERT_TRUE(master->Activate().ok());
    std::vector<int> flood;
    RigMeasurement m;
    RigCommand command;
    command.enable = true;
    int fresh = 0;
    for (int k = 0; k < 200; ++k) {
      if (k % 10 == 0) flood.push_back(ConnectRaw(rig.port()));
      command.sequence = static_cast<std::uint16_t>(k);
      fresh += master->Read(&m) == IoResult::kFresh;
      EXPECT_NE(master->Write(command), IoResult::kError) << k;
      Pass(1e-3);
    }
    EXPECT_GE(fresh, 190) << idle_count;
    EXPECT_EQ(master->reconnects(), 0) << idle_count;
    const Status released = master->Deactivate();
    EXPECT_TRUE(released.ok()) << released.message();
    EXPECT_NE(rig.Notes().find("connections (the most it serves): closed "
                               "client"),
              std::string::npos)
        << rig.Notes();
    for (int fd : idle) close(fd);
    for (int fd : flood) close(fd);
  }
}

// Sixteen clients at work (each sent a request within the second): no
// place to take, so a new master is turned away at once, and its error
// says so instead of "Connection reset by peer".
TEST_P(ModbusRigTest, AMasterTurnedAwayIsToldWhy) {
  InProcessRig rig(map_, rig_clock());
  std::vector<int> busy;
  const std::uint8_t read[12] = {0, 1, 0, 0, 0, 6, 1, 4, 0, 0, 0, 1};
  for (int k = 0; k < ModbusServer::kMaxClients; ++k) {
    busy.push_back(ConnectRaw(rig.port()));
    ASSERT_EQ(send(busy.back(), read, sizeof(read), MSG_NOSIGNAL), 12);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  auto master = Master(rig.port());
  const Status refused = master->Configure();
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.message().find("the rig closed the connection at once"),
            std::string::npos)
      << refused.message();
  EXPECT_NE(rig.Notes().find("refused a connection"), std::string::npos)
      << rig.Notes();
  for (int fd : busy) close(fd);
}

INSTANTIATE_TEST_SUITE_P(VirtualClock, ModbusRigTest,
                         ::testing::Values(RigTime::kVirtual),
                         ::testing::PrintToStringParamName());
INSTANTIATE_TEST_SUITE_P(RealClock, ModbusRigTest,
                         ::testing::Values(RigTime::kReal),
                         ::testing::PrintToStringParamName());

TEST(ModbusUriTest, ParsesTcpAndRtuAndRejectsTheRest) {
  ModbusEndpoint e;
  ASSERT_TRUE(ParseModbusUri("modbus-tcp://10.0.0.2:1502", &e).ok());
  EXPECT_EQ(e.host, "10.0.0.2");
  EXPECT_EQ(e.port, 1502);
  ASSERT_TRUE(ParseModbusUri("modbus-rtu:///dev/ttyUSB0", &e).ok());
  EXPECT_TRUE(e.rtu);
  EXPECT_EQ(e.device, "/dev/ttyUSB0");
  EXPECT_FALSE(ParseModbusUri("modbus-tcp://host", &e).ok());
  EXPECT_FALSE(ParseModbusUri("modbus-tcp://host:0", &e).ok());
  EXPECT_FALSE(ParseModbusUri("tcp://host:502", &e).ok());
}

}  // namespace
}  // namespace kcrig
