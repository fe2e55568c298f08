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
//  - ConsoleImpact: the paper's run on `kcrig emulate` over Modbus at 1 kHz
//    with the real-time set-up (the loop pinned to CPU 1), five times
//    without the console and five times with it and three viewers
//    attached (on CPU 0: the operator's machine), in turn; /0: readers of
//    the stream that draw nothing, /1: headless Chromium pages, /2: the
//    readers among 50 idle connections, a stream never read and three
//    malformed requests;
//    counters `ratio_compute_p99` and `ratio_wakeup_p99` (median on /
//    median off; target: <= 1.1), the overruns of each, and
//    `console_cpu_percent` (the console's threads' CPU over the runs, of one
//    core; target with the feed's share from LiveFeedIngest: <= 5);
//  - LiveFeedIngest: the console feed's cost per cycle record on the
//    logger's thread; counter `cpu_percent_at_1khz`;
//  - SilRigRun: the paper's first run (6.7 s with its phases) on the
//    embedded SIL rig through the rig session, plant at 0.1 ms, on the
//    virtual clock; counter `cpu_ms_per_rig_s` (target: <= 30).
// Run: build/bin/rt_bench --benchmark_format=json
#include <dirent.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <thread>

#include "benchmark/benchmark.h"
#include "console/live_console.h"
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

// One run of the paper's experiment on `kcrig emulate` at `port` with the
// real-time set-up of `rig_config`; `monitor` may be null.
bool RunOnEmulator(const RigConfig& rig_config, int port, RunMonitor* monitor,
                   RigSessionResult* result) {
  ModbusMap map;
  ModbusEndpoint endpoint;
  if (!LoadModbusMap(Rig().modbus.map_file, &map).ok() ||
      !ParseModbusUri("modbus-tcp://127.0.0.1:" + std::to_string(port),
                      &endpoint)
           .ok()) {
    return false;
  }
  ModbusRig rig(endpoint, map, Rig().modbus);
  if (!rig.Configure().ok()) return false;
  RigSessionOptions options;
  options.excitation = PaperRun().excitation;
  options.monitor = monitor;
  const Status status =
      RunRigSession(Config(), rig_config, &rig, options, result);
  if (!status.ok() || !result->completed) {
    std::fprintf(
        stderr, "rt_bench: the run failed: %s\n",
        status.ok() ? result->trip_message.c_str() : status.message().c_str());
  }
  return status.ok() && result->completed;
}

// CPU time [s] of this process's threads called `name` (/proc's comm),
// from schedstat (ns; stat's ticks are 10 ms).
double ThreadCpuSeconds(const std::string& name) {
  double seconds = 0;
  DIR* tasks = opendir("/proc/self/task");
  if (tasks == nullptr) return 0;
  while (const dirent* task = readdir(tasks)) {
    if (task->d_name[0] == '.') continue;
    const std::string dir = std::string("/proc/self/task/") + task->d_name;
    std::ifstream comm(dir + "/comm");
    std::string thread;
    std::getline(comm, thread);
    if (thread != name) continue;
    std::ifstream schedstat(dir + "/schedstat");
    double on_cpu_ns = 0;
    if (schedstat >> on_cpu_ns) seconds += on_cpu_ns * 1e-9;
  }
  closedir(tasks);
  return seconds;
}

// Viewers of the console at `url` on CPU `cpu` (taskset), standing for
// the operator's machine, which is not the rig controller: headless
// Chromium pages (each in a profile of its own), or plain readers of the
// page's stream (curl), which draw nothing.
class Viewers {
 public:
  Viewers(const std::string& url, int count, int cpu, bool browsers) {
    const std::string cpus = std::to_string(cpu);
    const std::string stream =
        url.substr(0, url.find('?')) + "events" + url.substr(url.find('?'));
    for (int i = 0; i < count; ++i) {
      const std::string profile = "--user-data-dir=" + Profile(i);
      std::vector<const char*> argv = {"taskset", "-c", cpus.c_str()};
      if (browsers) {
        argv.insert(argv.end(), {"chromium", "--headless=new", "--no-sandbox",
                                 "--disable-gpu", "--disable-dev-shm-usage",
                                 profile.c_str(), url.c_str()});
      } else {
        argv.insert(argv.end(),
                    {"curl", "-sN", "-o", "/dev/null", stream.c_str()});
      }
      argv.push_back(nullptr);
      posix_spawn_file_actions_t actions;
      posix_spawn_file_actions_init(&actions);
      posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
      pid_t pid = -1;
      if (posix_spawnp(&pid, "taskset", &actions, nullptr,
                       const_cast<char**>(argv.data()), environ) == 0) {
        pids_.push_back(pid);
      }
      posix_spawn_file_actions_destroy(&actions);
    }
  }
  ~Viewers() {
    for (pid_t pid : pids_) kill(pid, SIGTERM);
    for (pid_t pid : pids_) waitpid(pid, nullptr, 0);
    for (std::size_t i = 0; i < pids_.size(); ++i) {
      std::error_code ignored;
      std::filesystem::remove_all(Profile(static_cast<int>(i)), ignored);
    }
  }

 private:
  static std::string Profile(int i) {
    return "/tmp/kcrig_bench_chromium_" + std::to_string(getpid()) + "_" +
           std::to_string(i);
  }
  std::vector<pid_t> pids_;
};

// Clients that misbehave at the console on `port`: 50 connections that
// send nothing, a stream opened and never read, and three malformed
// requests (a TLS hello, a 100 kB header, a made-up method).
class HostileClients {
 public:
  HostileClients(int port, const std::string& token) {
    for (int i = 0; i < 50; ++i) Connect(port);
    const int stalled = Connect(port);
    const int small = 4096;
    setsockopt(stalled, SOL_SOCKET, SO_RCVBUF, &small, sizeof(small));
    Send(stalled,
         "GET /events?token=" + token + " HTTP/1.1\r\nHost: x\r\n\r\n");
    Send(Connect(port), std::string("\x16\x03\x01\x02\x00\x01\x00", 7));
    Send(Connect(port), "GET / HTTP/1.1\r\nX: " + std::string(100000, 'a'));
    Send(Connect(port), "BREW /coffee HTCPCP/1.0\r\n\r\n");
  }
  ~HostileClients() {
    for (int fd : sockets_) close(fd);
  }

 private:
  int Connect(int port) {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<std::uint16_t>(port));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof(address));
    sockets_.push_back(fd);
    return fd;
  }
  static void Send(int fd, const std::string& text) {
    [[maybe_unused]] const ssize_t sent =
        send(fd, text.data(), text.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  }
  std::vector<int> sockets_;
};

// How a run is watched: three stream readers, three headless Chromium
// pages, or three stream readers among hostile clients.
enum class Watchers { kReaders = 0, kBrowsers = 1, kReadersAndHostile = 2 };

// One run with the console and its watchers attached; false on failure.
bool RunWatched(const RigConfig& rig_config, int port, Watchers watchers,
                RigSessionResult* result, double* console_cpu, int* viewers) {
  std::unique_ptr<LiveConsole> console;
  ConsoleOptions options;
  options.address = "127.0.0.1:0";
  options.plotly_js = KCRIG_PLOTLY_JS;
  options.loop_cpu = rig_config.realtime.cpu;
  if (!LiveConsole::Start(options, &console).ok()) return false;
  const Viewers attached(console->url(), 3, 0, watchers == Watchers::kBrowsers);
  for (int k = 0; k < 600 && console->viewers() < 3; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  const std::string& url = console->url();
  const int console_port =
      std::stoi(url.substr(url.rfind(':') + 1, url.find('/', 7)));
  std::unique_ptr<HostileClients> hostile;
  if (watchers == Watchers::kReadersAndHostile) {
    hostile = std::make_unique<HostileClients>(
        console_port, url.substr(url.find("token=") + 6));
  }
  *viewers = std::min(*viewers, console->viewers());
  const double cpu_start = ThreadCpuSeconds("kcrig-console");
  if (!RunOnEmulator(rig_config, port, &console->feed(), result)) return false;
  *console_cpu += ThreadCpuSeconds("kcrig-console") - cpu_start;
  return true;
}

double Median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

void BM_ConsoleImpact(benchmark::State& state) {
  EmulatorProcess emulator;
  if (emulator.port() == 0) {
    state.SkipWithError("kcrig emulate did not start");
    return;
  }
  // The loop on CPU 1, the browsers on CPU 0; runs off and on alternate.
  RigConfig rig_config = Rig();
  rig_config.realtime.cpu = 1;
  constexpr int kPairs = 5;
  std::map<std::string, std::vector<double>> p99;
  std::int64_t overruns_off = 0, overruns_on = 0, cycles_on = 0;
  double console_cpu = 0;
  int viewers = 3;
  for (auto _ : state) {
    for (int pair = 0; pair < kPairs; ++pair) {
      RigSessionResult off, on;
      if (!RunOnEmulator(rig_config, emulator.port(), nullptr, &off) ||
          !RunWatched(rig_config, emulator.port(),
                      static_cast<Watchers>(state.range(0)), &on, &console_cpu,
                      &viewers)) {
        state.SkipWithError("a run failed");
        return;
      }
      for (const char* phase : {"compute", "wakeup"}) {
        p99[std::string(phase) + "_off"].push_back(
            off.timing.phases.at(phase).p99_us);
        p99[std::string(phase) + "_on"].push_back(
            on.timing.phases.at(phase).p99_us);
      }
      overruns_off += off.loop.overruns;
      overruns_on += on.loop.overruns;
      cycles_on += on.loop.cycles;
    }
  }
  for (const char* phase : {"compute", "wakeup"}) {
    const double off = Median(p99[std::string(phase) + "_off"]);
    const double on = Median(p99[std::string(phase) + "_on"]);
    state.counters[std::string(phase) + "_p99_off_us"] = off;
    state.counters[std::string(phase) + "_p99_on_us"] = on;
    state.counters[std::string("ratio_") + phase + "_p99"] = on / off;
  }
  state.counters["overruns_off"] = static_cast<double>(overruns_off);
  state.counters["overruns_on"] = static_cast<double>(overruns_on);
  state.counters["viewers"] = viewers;
  const double seconds = static_cast<double>(cycles_on) * Rig().period;
  state.counters["console_cpu_percent"] = 100 * console_cpu / seconds;
}
// Watchers: 0 three stream readers, 1 three Chromium pages, 2 three
// stream readers among hostile clients.
BENCHMARK(BM_ConsoleImpact)
    ->Arg(0)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

void BM_LiveFeedIngest(benchmark::State& state) {
  LiveFeed feed({});
  RunMonitor::Run run;
  run.limits = Rig().safety;
  feed.RunStarted(run);
  CycleRecord record;
  record.phase = RunPhase::kRamp;
  record.fresh = true;
  std::int64_t cycle = 0;
  for (auto _ : state) {
    record.cycle = cycle++;
    record.force[1] = static_cast<double>(cycle % 4000);
    feed.CycleLogged(record);
  }
  // Seconds per record (the inverted rate of 1 per iteration) times 1000
  // records a second, in percent: 1e5 / (1 / t) = t * 1e5.
  state.counters["cpu_percent_at_1khz"] =
      benchmark::Counter(1e-5, benchmark::Counter::kIsIterationInvariantRate |
                                   benchmark::Counter::kInvert);
}
BENCHMARK(BM_LiveFeedIngest);

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
