// The console's feed (what the page is sent) and its server's safe
// defaults, without a browser: spikes survive the decimation, a run faster
// than real time is merged rather than flooding, memory stays bounded over
// a long run, a stalled viewer is told so, a trip is sent at once, user
// strings never throw; the address rules; the virtual clock's pace.
#include "console/live_feed.h"

#include <chrono>
#include <cmath>
#include <memory>
#include <string>

#include "console/live_console.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "rt_core/runtime/clock.h"
#include "rt_core/runtime/cycle_timer.h"

namespace kcrig {
namespace {

using nlohmann::json;

RunMonitor::Run TestRun() {
  RunMonitor::Run run;
  run.rig = "test rig";
  run.period = 1e-3;
  run.duration = 10;
  run.real_time = false;
  return run;
}

CycleRecord Record(std::int64_t cycle) {
  CycleRecord r;
  r.cycle = cycle;
  r.fresh = true;
  r.phase = RunPhase::kRamp;
  return r;
}

// The data of every message of `event` in an SSE text.
std::vector<json> Events(const std::string& text, const std::string& event) {
  std::vector<json> found;
  const std::string head = "event: " + event + "\ndata: ";
  for (std::size_t at = text.find(head); at != std::string::npos;
       at = text.find(head, at + 1)) {
    const std::size_t begin = at + head.size();
    found.push_back(
        json::parse(text.substr(begin, text.find('\n', begin) - begin)));
  }
  return found;
}

// Every message after *seq: a read copies a bounded part (its cap counts
// what its string holds), so each pass reads into a string of its own.
std::string ReadAll(const LiveFeed& feed, std::uint64_t* seq) {
  std::string out;
  for (;;) {
    std::string part;
    feed.ReadAfter(seq, &part, std::chrono::milliseconds(0));
    if (part.empty()) return out;
    out += part;
  }
}

TEST(LiveFeedTest, AOneCycleSpikeSurvivesTheDecimation) {
  LiveFeed::Options options;
  options.max_bins_per_update = 1000;  // the 100 bins in one update
  LiveFeed feed(options);
  feed.RunStarted(TestRun());
  for (std::int64_t c = 0; c < 2000; ++c) {
    CycleRecord r = Record(c);
    r.force[0] = c == 1234 ? 4321.0 : 1.0;
    feed.CycleLogged(r);
  }
  feed.RunEnded(true, "completed", LoopResult());
  std::uint64_t seq = 0;
  const json snapshot = Events(feed.Snapshot(&seq), "snapshot").at(0);
  double highest = 0;
  std::size_t bins = 0;
  for (const json& bin : snapshot["history"]) {
    highest = std::max(highest, bin[3][3].get<double>());  // hi of Fx
    ++bins;
  }
  EXPECT_EQ(highest, 4321.0);
  // 2 s of run in 20 ms bins (a phase change may split one).
  EXPECT_GE(bins, 100u);
  EXPECT_LE(bins, 102u);
}

TEST(LiveFeedTest, ARunFasterThanRealTimeIsMergedAndBounded) {
  LiveFeed::Options options;
  options.max_bins_per_update = 50;
  options.history_bins = 3000;
  LiveFeed feed(options);
  feed.RunStarted(TestRun());
  std::uint64_t seq = 0;
  feed.Snapshot(&seq);
  // An hour of run at 1 kHz, as fast as the CPU allows.
  const std::int64_t cycles = 3'600'000;
  std::size_t most_bins = 0, most_bytes = 0;
  for (std::int64_t c = 0; c < cycles; ++c) {
    CycleRecord r = Record(c);
    r.y[2] = c == 2'000'017 ? -0.0123 : 0.0;
    feed.CycleLogged(r);
    if (c % 100'000 == 0) most_bytes = std::max(most_bytes, feed.held_bytes());
  }
  for (const json& bins : Events(ReadAll(feed, &seq), "bins")) {
    most_bins = std::max(most_bins, bins.size());
  }
  EXPECT_LE(most_bins, 50u);
  EXPECT_LT(most_bytes, 20u << 20);
  const json snapshot = Events(feed.Snapshot(&seq), "snapshot").at(0);
  EXPECT_LE(snapshot["history"].size(), 3000u);
  double lowest = 0;
  for (const json& bin : snapshot["history"]) {
    lowest = std::min(lowest, bin[2][8].get<double>());  // lo of z
  }
  EXPECT_FLOAT_EQ(lowest, -0.0123f);
}

TEST(LiveFeedTest, AViewerThatFallsBehindTheLogIsToldItStalled) {
  LiveFeed::Options options;
  options.update_seconds = 0;
  options.max_messages = 50;
  LiveFeed feed(options);
  std::uint64_t stalled = 0, reading = 0;
  feed.Snapshot(&stalled);
  feed.Snapshot(&reading);
  feed.RunStarted(TestRun());
  std::string out;
  for (std::int64_t c = 0; c < 5000; ++c) {
    feed.CycleLogged(Record(c));
    if (c % 10 == 0) {
      out.clear();
      EXPECT_EQ(feed.ReadAfter(&reading, &out, std::chrono::milliseconds(0)),
                LiveFeed::Read::kMessages);
    }
  }
  out.clear();
  EXPECT_EQ(feed.ReadAfter(&stalled, &out, std::chrono::milliseconds(0)),
            LiveFeed::Read::kStalled);
  feed.End("done");
  out.clear();
  EXPECT_EQ(feed.ReadAfter(&reading, &out, std::chrono::milliseconds(0)),
            LiveFeed::Read::kEnded);
  EXPECT_EQ(Events(out, "end").at(0), "done");
}

TEST(LiveFeedTest, ATripIsSentWithItsCauseAtOnce) {
  LiveFeed::Options options;
  options.update_seconds = 3600;  // no periodic update
  LiveFeed feed(options);
  feed.RunStarted(TestRun());
  std::uint64_t seq = 0;
  feed.Snapshot(&seq);
  for (std::int64_t c = 0; c < 10; ++c) feed.CycleLogged(Record(c));
  CycleRecord r = Record(10);
  r.cause = TripCause::kTravelLimit;
  r.trip_channel = 2;
  r.safety = SafetyState::kRampDown;
  feed.CycleLogged(r);
  const std::vector<json> trips = Events(ReadAll(feed, &seq), "trip");
  ASSERT_EQ(trips.size(), 1u);
  EXPECT_EQ(trips[0]["cause"], "travel_limit");
  EXPECT_NE(trips[0]["message"].get<std::string>().find("z beyond its limit"),
            std::string::npos)
      << trips[0];
  EXPECT_DOUBLE_EQ(trips[0]["t_s"].get<double>(), 0.010);
}

TEST(LiveFeedTest, UserStringsNeverThrowAndStayText) {
  LiveFeed feed({});
  RunMonitor::Run run = TestRun();
  run.log_dir = "/tmp/\xff\xfe<script>alert(1)</script>";
  feed.RunStarted(run);
  feed.Title("kcrig run \"quoted\" \xc3");
  feed.Iteration("not json");
  feed.Note("<b>bold</b>");
  std::uint64_t seq = 0;
  const json snapshot = Events(feed.Snapshot(&seq), "snapshot").at(0);
  EXPECT_NE(snapshot["run"]["log_dir"].get<std::string>().find("<script>"),
            std::string::npos);
  EXPECT_EQ(snapshot["iterations"].size(), 0u);
  EXPECT_EQ(snapshot["notes"].size(), 2u);  // the refused iteration's too
}

ConsoleOptions TestConsole(const std::string& address) {
  ConsoleOptions options;
  options.address = address;
  options.plotly_js = KCRIG_PLOTLY_JS;
  return options;
}

TEST(LiveConsoleTest, ListensOnLoopbackAndRefusesOtherAddressesUnlessAllowed) {
  std::unique_ptr<LiveConsole> console;
  ASSERT_TRUE(LiveConsole::Start(TestConsole("0"), &console).ok());
  EXPECT_EQ(console->url().rfind("http://127.0.0.1:", 0), 0u) << console->url();
  EXPECT_FALSE(console->remote());
  const std::string token = console->url().substr(console->url().find("=") + 1);
  EXPECT_EQ(token.size(), 64u);
  std::unique_ptr<LiveConsole> second;
  ASSERT_TRUE(LiveConsole::Start(TestConsole("localhost:0"), &second).ok());
  EXPECT_NE(second->url().substr(second->url().find("=") + 1), token);

  const Status remote = LiveConsole::Start(TestConsole("0.0.0.0:0"), &second);
  ASSERT_FALSE(remote.ok());
  EXPECT_NE(remote.message().find("--console-remote"), std::string::npos);
  ConsoleOptions allowed = TestConsole("0.0.0.0:0");
  allowed.allow_remote = true;
  ASSERT_TRUE(LiveConsole::Start(allowed, &second).ok());
  EXPECT_TRUE(second->remote());

  for (const char* bad : {"127.0.0.1:99999", "127.0.0.1:", ":80", "x:y",
                          "no-such-host.invalid:0", "[::1]:0", "::1"}) {
    const Status status = LiveConsole::Start(TestConsole(bad), &second);
    EXPECT_FALSE(status.ok()) << bad;
    EXPECT_EQ(status.message().rfind("--console ", 0), 0u) << status.message();
  }
  // A port in use.
  const std::string port =
      console->url().substr(17, console->url().find('/', 17) - 17);
  const Status taken =
      LiveConsole::Start(TestConsole("127.0.0.1:" + port), &second);
  EXPECT_FALSE(taken.ok());
}

TEST(LiveConsoleTest, StopsAtOnceHoweverSoonAfterItStarted) {
  for (int i = 0; i < 4; ++i) {
    std::unique_ptr<LiveConsole> console;
    ASSERT_TRUE(LiveConsole::Start(TestConsole("0"), &console).ok());
    if (i % 2 == 0) console->Shutdown("stopped at once");
  }
}

TEST(VirtualClockTest, APacedClockNeverRunsAheadOfItsPace) {
  VirtualClock clock;
  clock.set_pace(2.0);  // twice real time
  const std::int64_t start = MonotonicNanoseconds();
  for (int step = 1; step <= 200; ++step) {
    clock.SleepUntil(step * 1'000'000LL);  // 200 ms of virtual time
  }
  // Sleeps never return early: at least 100 ms of wall time passed.
  EXPECT_GE(MonotonicNanoseconds() - start, 99'000'000);
  EXPECT_EQ(clock.Now(), 200'000'000);
}

}  // namespace
}  // namespace kcrig
