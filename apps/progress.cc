#include "apps/progress.h"

#include <sys/ioctl.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <utility>

namespace kcrig {
namespace {

std::atomic<int> g_stop_signal{0};
static_assert(std::atomic<int>::is_always_lock_free,
              "the signal handlers store into it");

std::atomic<int> g_stop_count{0};

// The first signal asks for the ramp-down; a second one does not cut it
// short (a rig left at force by an impatient Ctrl-C is worse than a wait)
// but says how to; a third acts as usual: the rig's own watchdog then
// stops it. write() and raise() are async-signal-safe.
extern "C" void OnStopSignal(int signal) {
  const int count = ++g_stop_count;
  if (count == 1) {
    g_stop_signal.store(signal);
  } else if (count == 2) {
    const int saved_errno = errno;  // the interrupted code's
    constexpr char kLine[] =
        "\nkcrig: stopping safely (a rig ramps down to zero force first); "
        "once more to kill at once (a rig's own watchdog then stops it)\n";
    [[maybe_unused]] const ssize_t n =
        write(STDERR_FILENO, kLine, sizeof(kLine) - 1);
    errno = saved_errno;
  } else {
    std::signal(signal, SIG_DFL);
    raise(signal);
  }
}

std::atomic<int> g_emergency_stop{0};

extern "C" void OnEmergencyStop(int signal) {
  g_emergency_stop.store(signal == SIGUSR1 ? 1 : 2);
}

}  // namespace

std::atomic<int>& EmergencyStopButton() {
  static const bool installed = [] {
    struct sigaction action {};
    action.sa_handler = OnEmergencyStop;
    sigemptyset(&action.sa_mask);
    return sigaction(SIGUSR1, &action, nullptr) == 0 &&
           sigaction(SIGUSR2, &action, nullptr) == 0;
  }();
  (void)installed;
  return g_emergency_stop;
}

void RequestOperatorStop() {
  int none = 0;
  if (g_stop_signal.compare_exchange_strong(none, SIGINT)) ++g_stop_count;
}

const std::atomic<int>& InstallStopSignalHandlers() {
  struct sigaction action {};
  action.sa_handler = OnStopSignal;
  action.sa_flags = 0;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  std::signal(SIGPIPE, SIG_IGN);
  return g_stop_signal;
}

ProgressLine::ProgressLine(bool quiet)
    : enabled_(!quiet && isatty(STDERR_FILENO)) {}

ProgressLine::~ProgressLine() { Clear(); }

void ProgressLine::Show(const std::string& text) {
  if (!enabled_) return;
  winsize size{};
  std::string line = text;
  if (ioctl(STDERR_FILENO, TIOCGWINSZ, &size) == 0 && size.ws_col > 1 &&
      line.size() >= size.ws_col) {
    line.resize(size.ws_col - 1);
  }
  // \r and erase-to-end-of-line: the line is rewritten, never scrolled.
  std::fprintf(stderr, "\r\033[K%s", line.c_str());
  std::fflush(stderr);
  shown_ = true;
}

void ProgressLine::Show(const std::string& text, double fraction) {
  if (!enabled_) return;
  if (fraction == 0 && last_fraction_ != 0) {
    start_ = std::chrono::steady_clock::now();
  }
  last_fraction_ = fraction;
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_)
          .count();
  char tail[96];
  if (fraction >= 0.02 && fraction < 1) {
    std::snprintf(tail, sizeof(tail), " | %.0f %%, %.0f s, ~%.0f s left",
                  100 * fraction, elapsed, elapsed * (1 - fraction) / fraction);
  } else {
    std::snprintf(tail, sizeof(tail), " | %.0f s", elapsed);
  }
  Show(text + tail);
}

void ProgressLine::Clear() {
  if (!enabled_ || !shown_) return;
  std::fprintf(stderr, "\r\033[K");
  std::fflush(stderr);
  shown_ = false;
}

StopSignal::StopSignal() : signal_(&InstallStopSignalHandlers()) {}

IterationCallback StopSignal::Callback(
    std::function<void(const IterationSummary&)> show) const {
  return [this, show = std::move(show)](const IterationSummary& summary) {
    if (show) show(summary);
    return received() ? CallbackReturn::kAbort : CallbackReturn::kContinue;
  };
}

int StopSignal::Exit(const std::string& command,
                     const std::string& outcome) const {
  const int signal = signal_->load();
  std::fprintf(stderr, "kcrig %s: interrupted (%s); %s\n", command.c_str(),
               signal == SIGTERM ? "SIGTERM" : "SIGINT", outcome.c_str());
  return 128 + signal;
}

}  // namespace kcrig
