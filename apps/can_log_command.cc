#include "apps/can_log_command.h"

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include "apps/cli_util.h"
#include "apps/progress.h"
#include "io_drivers/socket_can.h"
#include "records/can_bus_log.h"

namespace kcrig {
namespace {

struct CanLogArgs {
  std::string interface;
  std::string out;
  double duration = 0;
};

int RunCanLog(const CanLogArgs& args) {
  const CommandError fail("can-log");
  if (!(args.duration >= 0 && args.duration <= 86400)) {
    return fail(Status::Error("--duration: must be within [0, 86400] s"));
  }
  CanSocket socket;
  CanSocketOptions options;
  options.interface = args.interface;
  options.error_frames = true;  // every frame, error frames too
  Status status = socket.Open(options);
  if (!status.ok()) return fail(status);
  CanBusLog log;
  status = log.Open(args.out, args.interface);
  if (!status.ok()) return fail(status);
  const std::atomic<int>& stop = InstallStopSignalHandlers();
  std::printf("kcrig can-log: logging can:%s to %s until %s\n",
              args.interface.c_str(), args.out.c_str(),
              args.duration > 0 ? "the duration ends or SIGINT" : "SIGINT");
  std::fflush(stdout);
  const auto end =
      std::chrono::steady_clock::now() +
      std::chrono::microseconds(static_cast<long>(args.duration * 1e6));
  TimedCanFrame frame;
  int error = 0;
  std::int64_t frames = 0, receive_errors = 0;
  while (stop.load() == 0 &&
         (args.duration == 0 || std::chrono::steady_clock::now() < end)) {
    socket.WaitReadable(0.05);
    while (socket.Receive(&frame, &error)) {
      log.Push(frame);
      ++frames;
    }
    if (error != 0) ++receive_errors;
  }
  status = log.Close();
  if (!status.ok()) return fail(status);
  std::printf(
      "kcrig can-log: %lld frames, %llu dropped (log writer behind), %lld "
      "receive errors; wrote %s\n",
      static_cast<long long>(frames),
      static_cast<unsigned long long>(log.dropped()),
      static_cast<long long>(receive_errors), args.out.c_str());
  return 0;
}

}  // namespace

void AddCanLogCommand(CLI::App* app, std::function<int()>* run) {
  auto args = std::make_shared<CanLogArgs>();
  CLI::App* cmd = app->add_subcommand(
      "can-log",
      "Log every frame on a CAN interface in the candump -l format (as a CAN "
      "run's can.log), until --duration or SIGINT");
  cmd->add_option("--can", args->interface, "SocketCAN interface, e.g. can0")
      ->required();
  cmd->add_option("--out", args->out, "The log file (candump -l format)")
      ->required();
  cmd->add_option("--duration", args->duration,
                  "Stop after this long [s] (0: at SIGINT/SIGTERM)");
  cmd->callback([args, run] { *run = [args] { return RunCanLog(*args); }; });
}

}  // namespace kcrig
