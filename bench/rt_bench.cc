// Real-time figures of the HIL core (issue: HIL core), each as a latency
// distribution (counters in us: p50, p99, p999, max):
//  - CycleCompute: one cycle's compute phase (excitation + safety + the
//    model's semi-implicit Euler step) over a whole run profile with an
//    in-memory rig (target: p99 <= 10 us);
//  - ModbusRoundTrip: one function-4 read of the input registers from
//    `kcrig emulate` on loopback, both at their configured SCHED_FIFO
//    priorities (target: p99 <= 300 us);
//  - WakeupVsCyclictest: the loop's wake-up latency (ControlLoop::Run, 1 kHz,
//    SCHED_FIFO 80) and cyclictest's (rt-tests, same priority and interval)
//    back to back; counter `ratio_p99` (target: <= 1.5);
//  - CanCycleCodec: one cycle's CAN frames encoded and decoded, both ends
//    (target: <= 1 us);
//  - CanRoundTrip: KC_Command to `kcrig emulate --can vcan0` and its
//    sample back, in the guest of scripts/vcan_vm.sh (TCG: not
//    representative of a real machine);
//  - SilRigRun: the paper's first run (6.7 s with its phases) on the
//    embedded SIL rig through the rig session, plant at 0.1 ms, on the
//    virtual clock; counter `cpu_ms_per_rig_s` (target: <= 30).
// Run: build/bin/rt_bench --benchmark_format=json
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <thread>

#include "benchmark/benchmark.h"
#include "emulator/sil_rig.h"
#include "hil/rig_config.h"
#include "hil/rig_session.h"
#include "io_drivers/kc_rig_protocol.h"
#include "io_drivers/modbus_map.h"
#include "io_drivers/modbus_rig.h"
#include "io_drivers/socket_can.h"
#include "rt_core/model/model_config.h"
#include "rt_core/runtime/control_loop.h"
#include "rt_core/runtime/realtime.h"

extern char** environ;

namespace kcrig {
namespace {

const KcrigConfig& Config() {
  static const KcrigConfig config = [] {
    KcrigConfig c;
    if (!LoadConfig(KCRIG_BENCH_CONFIG_DIR, &c).ok()) std::abort();
    return c;
  }();
  return config;
}

const RigConfig& Rig() {
  static const RigConfig rig = [] {
    RigConfig r;
    if (!LoadRigConfig(KCRIG_BENCH_CONFIG_DIR, &r).ok()) std::abort();
    return r;
  }();
  return rig;
}

void Report(benchmark::State& state, const TimingStatistics& s,
            const std::string& prefix = "") {
  state.counters[prefix + "p50_us"] = s.Percentile(0.5) * 1e-3;
  state.counters[prefix + "p99_us"] = s.Percentile(0.99) * 1e-3;
  state.counters[prefix + "p999_us"] = s.Percentile(0.999) * 1e-3;
  state.counters[prefix + "max_us"] = s.max() * 1e-3;
  state.counters[prefix + "count"] = static_cast<double>(s.count());
}

// Paces a benchmark at 1 kHz on absolute deadlines, like the loop.
void SleepToNextMillisecond(std::int64_t* next) {
  *next += 1000000;
  const timespec ts{static_cast<time_t>(*next / 1000000000),
                    static_cast<long>(*next % 1000000000)};
  clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
}

// A rig that answers at once with a fixed sample.
class StaticRig : public RigInterface {
 public:
  Status Configure() override { return Status::Ok(); }
  Status Activate() override { return Status::Ok(); }
  Status Deactivate() override { return Status::Ok(); }
  void OnError() override {}
  IoResult Read(RigMeasurement* m) override {
    m->sample = ++sample_;
    m->status = kRigEnabled;
    return IoResult::kFresh;
  }
  IoResult Write(const RigCommand&) override { return IoResult::kFresh; }
  std::string Describe() const override { return "static"; }
  std::string CountersJson() const override { return "{}"; }

 private:
  std::uint32_t sample_ = 0;
};

LoopOptions PaperRun() {
  LoopOptions o;
  o.period = 1e-3;
  o.excitation = Config().experiment.Excitation(Config().experiment.phi,
                                                Config().experiment.z_a);
  o.profile = Rig().profile;
  o.safety = Rig().safety;
  o.safety.error_position_max = 1.0;  // the static rig is not the model
  o.safety.error_angle_max = 1.0;
  return o;
}

void BM_CycleCompute(benchmark::State& state) {
  TimingStatistics compute;
  for (auto _ : state) {
    StaticRig rig;
    SpscRing<CycleRecord> ring(1 << 14);
    ControlLoop loop(Config().model, PaperRun(), &rig, &ring, nullptr);
    CycleRecord record;
    for (std::int64_t k = 0; loop.Cycle(k); ++k) {
      while (ring.Pop(&record)) {
      }
    }
    // The loop's own compute-phase statistics: one per cycle.
    compute.Merge(loop.timing().compute);
  }
  Report(state, compute);
}
BENCHMARK(BM_CycleCompute)->Unit(benchmark::kMillisecond)->Iterations(5);

void BM_SilRigRun(benchmark::State& state) {
  PlantConfig plant;
  if (!LoadPlantConfig(KCRIG_BENCH_CONFIG_DIR, Config().model, &plant).ok()) {
    std::abort();
  }
  RigSessionOptions options;
  options.excitation = PaperRun().excitation;
  double rig_seconds = 0;
  const std::clock_t cpu_start = std::clock();
  for (auto _ : state) {
    SilRig rig(Config(), plant);
    if (!rig.Start().ok()) std::abort();
    auto link = rig.Connect({});
    options.clock = rig.clock();
    RigSessionResult result;
    if (!RunRigSession(Config(), Rig(), link.get(), options, &result).ok() ||
        !result.completed) {
      std::abort();
    }
    rig_seconds += static_cast<double>(result.loop.cycles) * Rig().period;
  }
  // CPU of the whole process (the loop's thread and the logger's) per
  // second of rig time.
  const double cpu_ms =
      1e3 * static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
  state.counters["rig_s_per_run"] = rig_seconds / state.iterations();
  state.counters["cpu_ms_per_rig_s"] = cpu_ms / rig_seconds;
}
BENCHMARK(BM_SilRigRun)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

// `kcrig emulate` as its own process, serving `option` `value` (a free
// Modbus port, or a CAN interface); ready once its start line matches
// `ready` (whose first group, if any, is the port).
class EmulatorProcess {
 public:
  EmulatorProcess(const char* option = "--modbus-tcp",
                  const char* value = "127.0.0.1:0",
                  const char* ready = "127\\.0\\.0\\.1:([0-9]+)") {
    output_ = "/tmp/kcrig_rt_bench_emulate_" + std::to_string(getpid());
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, output_.c_str(),
                                     O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const char* argv[] = {
        KCRIG_BINARY, "emulate", "--config", KCRIG_BENCH_CONFIG_DIR,
        option,       value,     nullptr};
    posix_spawn(&pid_, KCRIG_BINARY, &actions, nullptr,
                const_cast<char**>(argv), environ);
    posix_spawn_file_actions_destroy(&actions);
    const std::regex re(ready);
    // Up to 60 s: under qemu's TCG a process starts slowly.
    for (int k = 0; k < 6000 && !ready_; ++k) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
      std::ifstream in(output_);
      std::stringstream text;
      text << in.rdbuf();
      std::smatch match;
      const std::string s = text.str();
      if (std::regex_search(s, match, re)) {
        ready_ = true;
        if (match.size() > 1) port_ = std::stoi(match[1]);
      }
    }
  }
  ~EmulatorProcess() {
    kill(pid_, SIGTERM);
    waitpid(pid_, nullptr, 0);
    std::remove(output_.c_str());
  }
  int port() const { return port_; }
  bool ready() const { return ready_; }

 private:
  pid_t pid_ = -1;
  bool ready_ = false;
  int port_ = 0;
  std::string output_;
};

void BM_ModbusRoundTrip(benchmark::State& state) {
  EmulatorProcess emulator;
  if (emulator.port() == 0) {
    state.SkipWithError("kcrig emulate did not start");
    return;
  }
  ModbusMap map;
  LoadModbusMap(Rig().modbus.map_file, &map);
  ModbusEndpoint endpoint;
  ParseModbusUri("modbus-tcp://127.0.0.1:" + std::to_string(emulator.port()),
                 &endpoint);
  ModbusRig rig(endpoint, map, Rig().modbus);
  if (!rig.Configure().ok()) {
    state.SkipWithError("cannot connect to kcrig emulate");
    return;
  }
  const RealtimeReport realtime = SetUpRealtime(Rig().realtime);
  TimingStatistics round_trip;
  long errors = 0;
  RigMeasurement m;
  for (auto _ : state) {
    // 1 kHz like the loop, 5000 reads.
    std::int64_t next = MonotonicNanoseconds();
    for (int k = 0; k < 5000; ++k) {
      SleepToNextMillisecond(&next);
      const std::int64_t start = MonotonicNanoseconds();
      errors += rig.Read(&m) != IoResult::kFresh;
      round_trip.Record(MonotonicNanoseconds() - start);
    }
  }
  LeaveRealtime();
  Report(state, round_trip);
  state.counters["errors"] = static_cast<double>(errors);
  state.counters["sched_fifo"] = realtime.fifo;
}
BENCHMARK(BM_ModbusRoundTrip)->Unit(benchmark::kMillisecond)->Iterations(1);

// cyclictest's p99 from its histogram (-h: one line per us, "us count").
double CyclictestP99(int loops, int priority, std::string* error) {
  const std::string command = "cyclictest -q -m -p " +
                              std::to_string(priority) + " -i 1000 -l " +
                              std::to_string(loops) + " -h 2000 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) {
    *error = "cannot run cyclictest";
    return -1;
  }
  std::array<char, 512> line;
  std::vector<std::pair<int, long>> histogram;
  long total = 0;
  while (fgets(line.data(), line.size(), pipe) != nullptr) {
    int us = 0;
    long count = 0;
    if (line[0] != '#' &&
        std::sscanf(line.data(), "%d %ld", &us, &count) == 2) {
      histogram.emplace_back(us, count);
      total += count;
    }
  }
  if (pclose(pipe) != 0 || total == 0) {
    *error = "cyclictest failed (installed? rt-tests)";
    return -1;
  }
  long seen = 0;
  for (const auto& [us, count] : histogram) {
    seen += count;
    if (seen >= 0.99 * total) return us + 1.0;  // bins are 1 us wide
  }
  return histogram.back().first + 1.0;
}

void BM_WakeupVsCyclictest(benchmark::State& state) {
  const double seconds = 10;
  TimingStatistics kcrig_wakeup;
  double cyclictest_p99 = 0;
  for (auto _ : state) {
    LoopOptions options = PaperRun();
    options.excitation.fmax = 0;
    options.max_duration = seconds;
    SpscRing<CycleRecord> ring(1 << 15);
    ControlLoop loop(Config().model, options, nullptr, &ring, nullptr);
    SetUpRealtime(Rig().realtime);
    loop.Run();
    LeaveRealtime();
    kcrig_wakeup = loop.timing().wakeup;
    std::string error;
    cyclictest_p99 = CyclictestP99(static_cast<int>(seconds * 1000),
                                   Rig().realtime.priority, &error);
    if (cyclictest_p99 < 0) {
      state.SkipWithError(error.c_str());
      return;
    }
  }
  Report(state, kcrig_wakeup, "kcrig_");
  state.counters["cyclictest_p99_us"] = cyclictest_p99;
  state.counters["ratio_p99"] =
      kcrig_wakeup.Percentile(0.99) * 1e-3 / cyclictest_p99;
}
BENCHMARK(BM_WakeupVsCyclictest)->Unit(benchmark::kMillisecond)->Iterations(1);

const KcRigProtocol& Protocol() {
  static const KcRigProtocol protocol = [] {
    Dbc dbc;
    KcRigProtocol p;
    if (!LoadDbc(Rig().can.dbc_file, &dbc).ok() ||
        !p.Bind(dbc, Rig().can.dbc_file).ok()) {
      std::abort();
    }
    return p;
  }();
  return protocol;
}

// One cycle's CAN traffic through the DBC codec, both ends: the controller
// encodes KC_Command, the rig decodes it and encodes its sample (four
// frames), the controller puts the sample back together (target: <= 1 us).
void BM_CanCycleCodec(benchmark::State& state) {
  const KcRigProtocol& protocol = Protocol();
  KcSampleAssembler assembler(&protocol);
  KcCommand command;
  command.force << 1234.5, -2000, 3999.5;
  command.enable = true;
  command.session = 42;
  RigMeasurement sample;
  sample.force << 1234.5, -2000, 3999.5;
  sample.y << 1e-3, -2e-3, 3e-3, 1e-2, -2e-2, 3e-2;
  sample.status = kRigEnabled;
  RigMeasurement received;
  bool clamped = false;
  std::int64_t completed = 0;
  for (auto _ : state) {
    ++command.sequence;
    ++sample.sample;
    const CanFrame sent = protocol.EncodeCommand(command, &clamped);
    const KcCommand at_rig = protocol.DecodeCommand(sent, &clamped);
    sample.force = at_rig.force;
    CanFrame frames[kSampleFrames];
    protocol.EncodeSample(sample, frames, &clamped);
    for (const CanFrame& f : frames) {
      completed += assembler.Add(f, protocol.Classify(f), &received);
    }
    benchmark::DoNotOptimize(received);
  }
  if (completed != state.iterations()) state.SkipWithError("samples lost");
}
BENCHMARK(BM_CanCycleCodec);

// Controller -> `kcrig emulate --can vcan0` -> controller: KC_Command out,
// the sample's four frames back, 2000 times at 1 kHz. Needs vcan0 (run
// inside scripts/vcan_vm.sh: on its guest time the figures are those of a
// steady 500 MIPS virtual machine, not a real one's).
void BM_CanRoundTrip(benchmark::State& state) {
  if (access("/sys/class/net/vcan0", F_OK) != 0) {
    state.SkipWithError("no vcan0 (run through scripts/vcan_vm.sh run)");
    return;
  }
  EmulatorProcess emulator("--can", "vcan0", "on can:vcan0");
  if (!emulator.ready()) {
    state.SkipWithError("kcrig emulate --can vcan0 did not start");
    return;
  }
  const KcRigProtocol& protocol = Protocol();
  CanSocket socket;
  CanSocketOptions options;
  options.interface = "vcan0";
  options.filters = {{protocol.id(KcFrame::kForce), 0x7FF}};
  if (!socket.Open(options).ok()) {
    state.SkipWithError("cannot open vcan0");
    return;
  }
  const RealtimeReport realtime = SetUpRealtime(Rig().realtime);
  TimingStatistics round_trip;
  long timeouts = 0;
  KcCommand command;  // zero force, not enabled: the rig still answers
  for (auto _ : state) {
    std::int64_t next = MonotonicNanoseconds();
    for (int k = 0; k < 2000; ++k) {
      SleepToNextMillisecond(&next);
      TimedCanFrame stale;
      int error = 0;
      while (socket.Receive(&stale, &error)) {
      }
      bool clamped = false;
      ++command.sequence;
      const std::int64_t start = MonotonicNanoseconds();
      socket.Send(protocol.EncodeCommand(command, &clamped), &error);
      bool answered = false;
      while (!answered && MonotonicNanoseconds() - start < 20000000) {
        if (socket.WaitReadable(0.02)) {
          TimedCanFrame frame;
          answered = socket.Receive(&frame, &error);
        }
      }
      if (answered) {
        round_trip.Record(MonotonicNanoseconds() - start);
      } else {
        ++timeouts;
      }
    }
  }
  LeaveRealtime();
  Report(state, round_trip);
  state.counters["timeouts"] = static_cast<double>(timeouts);
  state.counters["sched_fifo"] = realtime.fifo;
}
BENCHMARK(BM_CanRoundTrip)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace
}  // namespace kcrig

BENCHMARK_MAIN();
