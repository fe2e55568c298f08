#include "console/live_console.h"

#include <arpa/inet.h>
#include <civetweb.h>
#include <dirent.h>
#include <netdb.h>
#include <netinet/in.h>
#include <pthread.h>
#include <sched.h>
#include <sys/random.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <thread>
#include <utility>

#include "base/input_file.h"
#include "console/console_page.h"
#include "rt_core/runtime/realtime.h"

namespace kcrig {
namespace {

// A request's whole head must arrive within this, a write to a viewer
// must progress within it.
constexpr int kIoTimeoutMs = 2000;
// A request's head (line and headers) at most; civetweb refuses more.
constexpr int kMaxRequestBytes = 8192;
// Workers beyond the viewers' streams: for the page and the stop.
constexpr int kSpareWorkers = 4;
// Accepted connections waiting for a worker; beyond them the kernel's
// backlog holds them.
constexpr int kQueuedConnections = 64;
// A stream's comment line this often finds a viewer that went away.
constexpr auto kKeepAlive = std::chrono::seconds(5);
// One write to a viewer at most: a slow one is found within kIoTimeoutMs.
constexpr std::size_t kMaxWriteBytes = 64u << 10;
// The kernel's send buffer per connection (doubled by the kernel), fixed
// so that it does not grow to megabytes on loopback: a viewer that stops
// reading fills it within seconds and is dropped.
constexpr int kSendBufferBytes = 64 << 10;
constexpr std::size_t kMaxPlotlyBytes = 32u << 20;

Status ParseAddress(const std::string& text, std::string* host, int* port) {
  const auto malformed = [&text] {
    return Status::Error("--console " + text +
                         ": expected HOST:PORT or PORT (0 picks a free port)");
  };
  std::string port_text = text;
  *host = "127.0.0.1";
  const std::size_t colon = text.rfind(':');
  if (colon != std::string::npos) {
    *host = text.substr(0, colon);
    port_text = text.substr(colon + 1);
    if (host->size() >= 2 && host->front() == '[' && host->back() == ']') {
      return Status::Error("--console " + text +
                           ": IPv6 addresses are not supported (the "
                           "console's server is built for IPv4)");
    }
    if (host->find(':') != std::string::npos) return malformed();
  }
  char* end = nullptr;
  errno = 0;
  const long value = std::strtol(port_text.c_str(), &end, 10);
  if (host->empty() || port_text.empty() || *end != '\0' || errno != 0 ||
      value < 0 || value > 65535) {
    return malformed();
  }
  *port = static_cast<int>(value);
  return Status::Ok();
}

// The IPv4 address `host` names (the first), as numbers: what is checked
// is what is bound. `loopback`: whether it is 127.0.0.0/8.
Status ResolveHost(const std::string& text, const std::string& host,
                   std::string* numeric, bool* loopback) {
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  const int error = getaddrinfo(host.c_str(), nullptr, &hints, &found);
  if (error != 0 || found == nullptr) {
    return Status::Error("--console " + text + ": " +
                         (error != 0 ? gai_strerror(error) : "no address"));
  }
  const auto* v4 = reinterpret_cast<const sockaddr_in*>(found->ai_addr);
  char name[INET_ADDRSTRLEN] = {};
  inet_ntop(AF_INET, &v4->sin_addr, name, sizeof(name));
  *numeric = name;
  *loopback = (ntohl(v4->sin_addr.s_addr) >> 24) == 127;
  freeaddrinfo(found);
  return Status::Ok();
}

// 256 bits from the kernel's random source, in hex.
Status RandomToken(std::string* token) {
  unsigned char bytes[32];
  if (getrandom(bytes, sizeof(bytes), 0) !=
      static_cast<ssize_t>(sizeof(bytes))) {
    return Status::Error("--console: no random token (getrandom: " +
                         std::string(std::strerror(errno)) + ")");
  }
  static const char kHex[] = "0123456789abcdef";
  token->clear();
  for (unsigned char b : bytes) {
    *token += kHex[b >> 4];
    *token += kHex[b & 15];
  }
  return Status::Ok();
}

// Compares in time independent of where they differ.
bool SameToken(const std::string& given, const std::string& token) {
  if (given.size() != token.size()) return false;
  unsigned char diff = 0;
  for (std::size_t i = 0; i < token.size(); ++i) {
    diff |= static_cast<unsigned char>(given[i] ^ token[i]);
  }
  return diff == 0;
}

// civetweb has no hook for its sockets' options: its listening socket,
// found by its port, gets the send buffer that accepted sockets inherit.
void LimitSendBuffers(int port) {
  DIR* fds = opendir("/proc/self/fd");
  if (fds == nullptr) return;
  while (const dirent* entry = readdir(fds)) {
    const int fd = std::atoi(entry->d_name);
    int listening = 0;
    socklen_t size = sizeof(listening);
    sockaddr_in address{};
    socklen_t address_size = sizeof(address);
    if (entry->d_name[0] == '.' || fd == dirfd(fds) ||
        getsockopt(fd, SOL_SOCKET, SO_ACCEPTCONN, &listening, &size) != 0 ||
        listening == 0 ||
        getsockname(fd, reinterpret_cast<sockaddr*>(&address), &address_size) !=
            0 ||
        address.sin_family != AF_INET || ntohs(address.sin_port) != port) {
      continue;
    }
    setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &kSendBufferBytes,
               sizeof(kSendBufferBytes));
  }
  closedir(fds);
}

std::string UrlHost(const std::string& host) {
  if (host == "0.0.0.0") {
    char name[256] = {};
    if (gethostname(name, sizeof(name) - 1) == 0 && name[0] != '\0') {
      return name;
    }
  }
  return host;
}

// The page with its plotting library inlined: one response, no file.
Status BuildPage(const std::string& plotly_path, std::string* page) {
  std::string plotly;
  const char* override_path = std::getenv("KCRIG_PLOTLY_JS");
  const std::string path =
      override_path != nullptr ? override_path : plotly_path;
  const Status status = ReadInputFile(path, kMaxPlotlyBytes, &plotly);
  if (!status.ok()) {
    return Status::Error("--console: plotly.js not found (" + status.message() +
                         "; Debian package python3-plotly, or "
                         "KCRIG_PLOTLY_JS names another copy)");
  }
  *page = kConsolePageHtml;
  for (const auto& [marker, text] :
       {std::pair<std::string, const char*>{"/*KCRIG_PLOTLY*/", plotly.c_str()},
        {"/*KCRIG_CONSOLE_SCRIPT*/", kConsolePageJs}}) {
    const std::size_t at = page->find(marker);
    if (at == std::string::npos) return Status::Error("console page: broken");
    page->replace(at, marker.size(), text);
  }
  return Status::Ok();
}

// Headers every response carries.
constexpr const char* kCommonHeaders =
    "Cache-Control: no-store\r\n"
    "X-Content-Type-Options: nosniff\r\n"
    "Referrer-Policy: no-referrer\r\n"
    "Connection: close\r\n";

int Respond(mg_connection* conn, int status, const char* reason,
            const char* type, const std::string& body,
            const char* extra_headers = "") {
  mg_printf(conn,
            "HTTP/1.1 %d %s\r\nContent-Type: %s\r\nContent-Length: %zu\r\n"
            "%s%s\r\n",
            status, reason, type, body.size(), kCommonHeaders, extra_headers);
  mg_write(conn, body.data(), body.size());
  return status;
}

// Writes `text` in pieces; false when the viewer went away or took longer
// than kIoTimeoutMs for one piece (a viewer that reads too slowly).
bool WriteToViewer(mg_connection* conn, const std::string& text) {
  for (std::size_t at = 0; at < text.size(); at += kMaxWriteBytes) {
    const std::size_t n = std::min(kMaxWriteBytes, text.size() - at);
    const auto start = std::chrono::steady_clock::now();
    if (mg_write(conn, text.data() + at, n) != static_cast<int>(n) ||
        std::chrono::steady_clock::now() - start >
            std::chrono::milliseconds(kIoTimeoutMs)) {
      return false;
    }
  }
  return true;
}

}  // namespace

LiveConsole::LiveConsole(ConsoleOptions options)
    : options_(std::move(options)), feed_([this] {
        LiveFeed::Options feed;
        feed.on_failure = options_.on_failure;
        return feed;
      }()) {}

Status LiveConsole::Start(ConsoleOptions options,
                          std::unique_ptr<LiveConsole>* console) {
  std::string host, numeric;
  int port = 0;
  bool loopback = true;
  KCRIG_RETURN_IF_ERROR(ParseAddress(options.address, &host, &port));
  KCRIG_RETURN_IF_ERROR(
      ResolveHost(options.address, host, &numeric, &loopback));
  if (!loopback && !options.allow_remote) {
    return Status::Error(
        "--console " + options.address +
        ": not a loopback address; anyone on that network who has the "
        "URL could watch and stop the run: add --console-remote to allow it");
  }
  std::unique_ptr<LiveConsole> made(new LiveConsole(std::move(options)));
  made->remote_ = !loopback;
  KCRIG_RETURN_IF_ERROR(RandomToken(&made->token_));
  KCRIG_RETURN_IF_ERROR(BuildPage(made->options_.plotly_js, &made->page_));
  KCRIG_RETURN_IF_ERROR(made->Listen(numeric, port));
  made->url_ = "http://" + UrlHost(numeric) + ":" +
               std::to_string(made->port_) + "/?token=" + made->token_;
  *console = std::move(made);
  return Status::Ok();
}

Status LiveConsole::Listen(const std::string& host, int port) {
  const std::string ports = host + ":" + std::to_string(port);
  const std::string threads =
      std::to_string(options_.max_viewers + kSpareWorkers);
  const std::string timeout = std::to_string(kIoTimeoutMs);
  const std::string request = std::to_string(kMaxRequestBytes);
  const std::string queue = std::to_string(kQueuedConnections);
  const char* config[] = {
      "listening_ports", ports.c_str(), "num_threads", threads.c_str(),
      "request_timeout_ms", timeout.c_str(), "max_request_size",
      request.c_str(), "connection_queue", queue.c_str(), "enable_keep_alive",
      "no", "enable_directory_listing", "no",
      // No CORS preflight answered by civetweb itself
      // (its default allows every origin): OPTIONS
      // reaches the token check like every request.
      "access_control_allow_origin", "", "access_control_allow_methods", "",
      "access_control_allow_headers", "", nullptr};
  mg_callbacks callbacks{};
  // The server's threads, made in mg_start: below the loop, off its CPU.
  callbacks.init_thread = [](const mg_context* context, int) -> void* {
    const auto* self =
        static_cast<const LiveConsole*>(mg_get_user_data(context));
    BelowTheLoop(self->options_.loop_cpu);
    return nullptr;
  };
  // The terminal is the run's: the server's own complaints stay off it.
  callbacks.log_message = [](const mg_connection*, const char*) { return 1; };
  mg_init_library(0);
  context_ = mg_start(&callbacks, this, config);
  mg_server_port bound{};
  if (context_ == nullptr || mg_get_server_ports(context_, 1, &bound) != 1) {
    return Status::Error("--console " + options_.address +
                         ": cannot listen there (in use, or not an address "
                         "of this machine)");
  }
  port_ = bound.port;
  LimitSendBuffers(port_);
  mg_set_request_handler(context_, "/", &LiveConsole::Handle, this);
  return Status::Ok();
}

void LiveConsole::BelowTheLoop(int loop_cpu) {
  sched_param none{};
  pthread_setschedparam(pthread_self(), SCHED_OTHER, &none);
  setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()), 5);
  pthread_setname_np(pthread_self(), "kcrig-console");
  KeepOffCpu(loop_cpu);
}

// Every request: the token first, then the page, its stream or the stop;
// nothing else exists. An exception never crosses into the C server.
int LiveConsole::Handle(mg_connection* conn, void* self_pointer) {
  auto* self = static_cast<LiveConsole*>(self_pointer);
  // Closed after the answer: civetweb then never reads the rest of a body
  // (which a client could trickle for ever).
  mg_disable_connection_keep_alive(conn);
  try {
    const mg_request_info* request = mg_get_request_info(conn);
    if (request->content_length > 0 ||
        mg_get_header(conn, "Transfer-Encoding") != nullptr) {
      return Respond(conn, 413, "Content Too Large", "text/plain",
                     "kcrig console: no request takes a body\n");
    }
    if (!self->Authorized(conn, request)) {
      return Respond(conn, 403, "Forbidden", "text/plain",
                     "kcrig console: refused without the token of the URL "
                     "kcrig printed\n");
    }
    const std::string method = request->request_method;
    const std::string path =
        request->local_uri != nullptr ? request->local_uri : "";
    if (method == "GET" && path == "/") return self->ServePage(conn);
    if (method == "GET" && path == "/events") return self->ServeStream(conn);
    if (method == "POST" && path == "/stop") {
      return self->Stop(conn, request->remote_addr);
    }
    return Respond(conn, 404, "Not Found", "text/plain",
                   "kcrig console: no such page\n");
  } catch (...) {
    // The run goes on; the viewer gets an error (when nothing was sent).
    mg_send_http_error(conn, 500, "%s", "kcrig console: internal error\n");
    return 500;
  }
}

bool LiveConsole::Authorized(mg_connection* conn,
                             const mg_request_info* request) const {
  const char* header = mg_get_header(conn, "X-Kcrig-Token");
  if (header != nullptr) return SameToken(header, token_);
  char given[128] = {};
  const char* query = request->query_string;
  return query != nullptr &&
         mg_get_var(query, std::strlen(query), "token", given, sizeof(given)) >
             0 &&
         SameToken(given, token_);
}

int LiveConsole::ServePage(mg_connection* conn) {
  // Scripts and styles inline only, connections to this console only.
  return Respond(conn, 200, "OK", "text/html; charset=utf-8", page_,
                 "Content-Security-Policy: default-src 'none'; script-src "
                 "'unsafe-inline' 'unsafe-eval'; style-src 'unsafe-inline'; "
                 "img-src data: blob:; font-src data:; connect-src 'self'; "
                 "base-uri 'none'; form-action 'none'; frame-ancestors "
                 "'none'\r\n");
}

int LiveConsole::Stop(mg_connection* conn, const std::string& from) {
  if (!stop_requested_.exchange(true)) {
    feed_.Note("operator stop from the console (" + from + "): ramping down");
    if (options_.on_stop) options_.on_stop();
  }
  return Respond(conn, 200, "OK", "application/json", "{\"stopping\":true}\n");
}

// The snapshot, then every message as it comes, until the feed ends, the
// console stops, or the viewer stalls or goes away.
int LiveConsole::ServeStream(mg_connection* conn) {
  // Counted on every way out, an exception's too.
  struct Viewer {
    std::atomic<int>* count;
    ~Viewer() { count->fetch_sub(1); }
  } viewer{&viewers_};
  if (viewers_.fetch_add(1) >= options_.max_viewers) {
    return Respond(conn, 503, "Service Unavailable", "text/plain",
                   "kcrig console: too many viewers\n");
  }
  std::uint64_t seq = 0;
  std::string out = feed_.Snapshot(&seq);
  mg_printf(conn,
            "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\n%s\r\n",
            kCommonHeaders);
  try {
    Stream(conn, seq, std::move(out));
  } catch (...) {
    // Headers are out: the stream just ends; the page reconnects.
  }
  return 200;
}

void LiveConsole::Stream(mg_connection* conn, std::uint64_t seq,
                         std::string out) {
  auto written = std::chrono::steady_clock::now() - kKeepAlive;
  for (;;) {
    feed_.FlushStage();
    const LiveFeed::Read read =
        feed_.ReadAfter(&seq, &out, std::chrono::milliseconds(250));
    if (read == LiveFeed::Read::kStalled || stopping_) break;
    const auto now = std::chrono::steady_clock::now();
    if (out.empty() && now - written >= kKeepAlive) out = ":\n\n";
    if (!out.empty()) {
      if (!WriteToViewer(conn, out)) break;
      written = now;
      out.clear();
    }
    if (read == LiveFeed::Read::kEnded) break;
  }
}

void LiveConsole::Shutdown(const std::string& outcome) {
  if (ending_.exchange(true)) return;
  // Every stream sends the end and closes itself; one that cannot within
  // the write timeout is cut.
  feed_.End(outcome);
  const auto until = std::chrono::steady_clock::now() +
                     std::chrono::milliseconds(kIoTimeoutMs);
  while (viewers_.load() > 0 && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  stopping_ = true;
  // Joins the server's threads, a read or write in progress seeing the
  // stop; civetweb's listening thread wakes from its poll within 2 s.
  if (context_ != nullptr) mg_stop(context_);
  context_ = nullptr;
}

LiveConsole::~LiveConsole() { Shutdown("kcrig ended"); }

}  // namespace kcrig
