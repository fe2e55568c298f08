// The operator console of `kcrig run` and `kcrig campaign` (--console):
// one page, served over HTTP by civetweb, that a browser opens to watch
// the run (its LiveFeed, pushed to the page as Server-Sent Events) and to
// stop it. Safe by default: it listens on loopback unless another address
// is allowed explicitly, every request must carry the random token of the
// URL printed on the terminal, it serves nothing but the page, its stream
// and the stop, and the page shows user strings as text. Never in the way
// of the loop: it is fed from the logger's thread, its own threads run
// below the loop's priority, a viewer that stalls is dropped, and its
// memory is bounded (a fixed number of viewers, a bounded feed).
#ifndef KCRIG_CONSOLE_LIVE_CONSOLE_H_
#define KCRIG_CONSOLE_LIVE_CONSOLE_H_

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "base/status.h"
#include "console/live_feed.h"

struct mg_connection;
struct mg_context;
struct mg_request_info;

namespace kcrig {

struct ConsoleOptions {
  // "HOST:PORT", "[IPv6]:PORT" or "PORT" (loopback); port 0 picks a free
  // one.
  std::string address;
  // An address that is not loopback is refused unless this is set: the
  // console is then reachable by anyone on that network who has the URL.
  bool allow_remote = false;
  // Streams served at once; a further viewer is refused (503).
  int max_viewers = 8;
  // The loop's CPU when rig.yaml pins it (realtime.cpu; -1: not pinned):
  // the console's threads keep off it, so that they neither take its time
  // nor its caches.
  int loop_cpu = -1;
  // The page's plotting library (plotly.js, as the report's).
  std::string plotly_js;
  // The stop button's action (the operator stop: the same ramp-down as
  // Ctrl-C). Called at most once, from a server thread.
  std::function<void()> on_stop;
  // One line when the console fails while the run goes on.
  std::function<void(const std::string&)> on_failure;
};

class LiveConsole {
 public:
  // Binds and starts serving; an error (in one line, naming --console)
  // when the address is malformed, not allowed or cannot be bound.
  static Status Start(ConsoleOptions options,
                      std::unique_ptr<LiveConsole>* console);
  ~LiveConsole();
  LiveConsole(const LiveConsole&) = delete;
  LiveConsole& operator=(const LiveConsole&) = delete;

  LiveFeed& feed() { return feed_; }
  // "http://127.0.0.1:8080/?token=...": what the operator opens.
  const std::string& url() const { return url_; }
  bool remote() const { return remote_; }
  // Streams open now.
  int viewers() const { return viewers_.load(); }

  // Ends the feed with `outcome`, gives the viewers up to the write
  // timeout (2 s) to receive it, stops serving (civetweb's listening
  // thread wakes within 2 s): at most about 4 s. Idempotent.
  void Shutdown(const std::string& outcome);

 private:
  explicit LiveConsole(ConsoleOptions options);
  Status Listen(const std::string& host, int port);
  static void BelowTheLoop(int loop_cpu);
  static int Handle(mg_connection* conn, void* self);
  bool Authorized(mg_connection* conn, const mg_request_info* request) const;
  int ServePage(mg_connection* conn);
  int ServeStream(mg_connection* conn);
  void Stream(mg_connection* conn, std::uint64_t seq, std::string out);
  int Stop(mg_connection* conn, const std::string& from);

  ConsoleOptions options_;
  LiveFeed feed_;
  mg_context* context_ = nullptr;
  int port_ = 0;
  std::string token_;
  std::string page_;
  std::string url_;
  bool remote_ = false;
  std::atomic<int> viewers_{0};
  std::atomic<bool> stop_requested_{false};
  std::atomic<bool> ending_{false};
  std::atomic<bool> stopping_{false};  // the server is being stopped
};

}  // namespace kcrig

#endif  // KCRIG_CONSOLE_LIVE_CONSOLE_H_
