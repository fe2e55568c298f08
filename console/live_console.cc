#include "console/live_console.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <mutex>
#include <random>
#include <utility>
#include <vector>

#include "base/input_file.h"
#include "console/console_page.h"
#include "httplib.h"
#include "rt_core/runtime/realtime.h"

namespace kcrig {
namespace {

constexpr int kIoTimeoutSeconds = 2;
// A stream's comment line this often keeps proxies open and finds a
// viewer that went away.
constexpr auto kKeepAlive = std::chrono::seconds(5);
// The kernel's buffer per viewer: a stalled one holds no more.
constexpr int kSendBufferBytes = 256 << 10;
constexpr std::size_t kMaxRequestBytes = 4096;
constexpr int kListenBacklog = 128;
// Workers beyond the viewers' streams: for the page, the stop, and
// connections that send nothing until the read timeout drops them.
constexpr int kSpareWorkers = 56;
constexpr std::size_t kMaxPlotlyBytes = 32u << 20;

Status ParseAddress(const std::string& text, std::string* host, int* port) {
  std::string port_text = text;
  *host = "127.0.0.1";
  const std::size_t colon = text.rfind(':');
  if (colon != std::string::npos) {
    *host = text.substr(0, colon);
    port_text = text.substr(colon + 1);
    if (host->size() >= 2 && host->front() == '[' && host->back() == ']') {
      *host = host->substr(1, host->size() - 2);
    }
  }
  char* end = nullptr;
  errno = 0;
  const long value = std::strtol(port_text.c_str(), &end, 10);
  if (host->empty() || port_text.empty() || *end != '\0' || errno != 0 ||
      value < 0 || value > 65535) {
    return Status::Error("--console " + text +
                         ": expected HOST:PORT or PORT (0 picks a free port)");
  }
  *port = static_cast<int>(value);
  return Status::Ok();
}

bool IsLoopback(const sockaddr* address) {
  if (address->sa_family == AF_INET) {
    const auto* v4 = reinterpret_cast<const sockaddr_in*>(address);
    return (ntohl(v4->sin_addr.s_addr) >> 24) == 127;
  }
  if (address->sa_family == AF_INET6) {
    const auto* v6 = reinterpret_cast<const sockaddr_in6*>(address);
    return IN6_IS_ADDR_LOOPBACK(&v6->sin6_addr);
  }
  return false;
}

// Whether every address `host` names is a loopback one.
Status ResolvesToLoopback(const std::string& host, bool* loopback) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  const int error = getaddrinfo(host.c_str(), nullptr, &hints, &found);
  if (error != 0) {
    return Status::Error("--console " + host + ": " + gai_strerror(error));
  }
  *loopback = true;
  for (const addrinfo* a = found; a != nullptr; a = a->ai_next) {
    *loopback = *loopback && IsLoopback(a->ai_addr);
  }
  freeaddrinfo(found);
  return Status::Ok();
}

std::string RandomToken() {
  std::random_device device;  // getrandom(2)
  std::string token;
  static const char kHex[] = "0123456789abcdef";
  for (int i = 0; i < 8; ++i) {
    const unsigned word = device();
    for (int shift = 0; shift < 32; shift += 8) {
      token += kHex[(word >> (shift + 4)) & 15];
      token += kHex[(word >> shift) & 15];
    }
  }
  return token;
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

// The console's threads run as ordinary, lower-priority work whatever the
// caller's policy, and off the loop's CPU when it has one of its own.
void BelowTheLoop(int loop_cpu) {
  sched_param none{};
  pthread_setschedparam(pthread_self(), SCHED_OTHER, &none);
  setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()), 5);
  pthread_setname_np(pthread_self(), "kcrig-console");
  KeepOffCpu(loop_cpu);
}

// The server's workers: a fixed number of threads with small stacks (a
// rig run locks every page of the process, mlockall) below the loop's
// priority. Enough of them that a few dozen connections that send nothing
// (each held until the read timeout) leave room for the viewers; beyond
// them connections wait in the queue (a socket each).
class ConsoleWorkers final : public httplib::TaskQueue {
 public:
  ConsoleWorkers(int count, int loop_cpu) : loop_cpu_(loop_cpu) {
    pthread_attr_t attributes;
    pthread_attr_init(&attributes);
    pthread_attr_setstacksize(&attributes, kStackBytes);
    for (int i = 0; i < count; ++i) {
      pthread_t thread;
      if (pthread_create(&thread, &attributes, &Work, this) == 0) {
        threads_.push_back(thread);
      }
    }
    pthread_attr_destroy(&attributes);
  }

  void enqueue(std::function<void()> job) override {
    std::lock_guard<std::mutex> lock(mutex_);
    jobs_.push_back(std::move(job));
    ready_.notify_one();
  }

  // Runs what is queued (each closes its socket), then joins.
  void shutdown() override {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
    }
    ready_.notify_all();
    for (pthread_t thread : threads_) pthread_join(thread, nullptr);
    threads_.clear();
  }

  ~ConsoleWorkers() override { shutdown(); }

 private:
  static constexpr std::size_t kStackBytes = 512u << 10;

  static void* Work(void* self) {
    auto* workers = static_cast<ConsoleWorkers*>(self);
    BelowTheLoop(workers->loop_cpu_);
    workers->Loop();
    return nullptr;
  }

  void Loop() {
    for (;;) {
      std::function<void()> job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        ready_.wait(lock, [this] { return stopping_ || !jobs_.empty(); });
        if (jobs_.empty()) return;
        job = std::move(jobs_.front());
        jobs_.pop_front();
      }
      job();
    }
  }

  int loop_cpu_;
  std::vector<pthread_t> threads_;
  std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<std::function<void()>> jobs_;
  bool stopping_ = false;
};

std::string UrlHost(const std::string& host) {
  if (host == "0.0.0.0" || host == "::") {
    char name[256] = {};
    if (gethostname(name, sizeof(name) - 1) == 0 && name[0] != '\0') {
      return name;
    }
  }
  return host.find(':') != std::string::npos ? "[" + host + "]" : host;
}

// The page with its plotting library inlined: one response, no file.
Status BuildPage(const std::string& plotly_path, std::string* page) {
  std::string plotly;
  const char* override_path = std::getenv("KCRIG_PLOTLY_JS");
  const std::string path =
      override_path != nullptr ? override_path : plotly_path;
  Status status = ReadInputFile(path, kMaxPlotlyBytes, &plotly);
  if (!status.ok()) {
    return Status::Error("--console: plotly.js not found (" + status.message() +
                         "; Debian package python3-plotly, or "
                         "KCRIG_PLOTLY_JS names another copy)");
  }
  *page = kConsolePageHtml;
  const std::pair<const char*, const std::string*> parts[] = {
      {"/*KCRIG_PLOTLY*/", &plotly}, {"/*KCRIG_CONSOLE_SCRIPT*/", nullptr}};
  const std::string script = kConsolePageJs;
  for (const auto& [marker, text] : parts) {
    const std::size_t at = page->find(marker);
    if (at == std::string::npos) {
      return Status::Error("console page: marker missing");
    }
    page->replace(at, std::strlen(marker), text != nullptr ? *text : script);
  }
  return Status::Ok();
}

}  // namespace

LiveConsole::LiveConsole(ConsoleOptions options)
    : options_(std::move(options)),
      feed_([this] {
        LiveFeed::Options feed;
        feed.on_failure = options_.on_failure;
        return feed;
      }()),
      server_(std::make_unique<httplib::Server>()),
      token_(RandomToken()) {}

Status LiveConsole::Start(ConsoleOptions options,
                          std::unique_ptr<LiveConsole>* console) {
  std::string host;
  int port = 0;
  KCRIG_RETURN_IF_ERROR(ParseAddress(options.address, &host, &port));
  bool loopback = true;
  KCRIG_RETURN_IF_ERROR(ResolvesToLoopback(host, &loopback));
  if (!loopback && !options.allow_remote) {
    return Status::Error(
        "--console " + options.address +
        ": not a loopback address; anyone on that network who has the "
        "URL could watch and stop the run: add --console-remote to allow it");
  }
  std::unique_ptr<LiveConsole> made(new LiveConsole(std::move(options)));
  made->remote_ = !loopback;
  KCRIG_RETURN_IF_ERROR(BuildPage(made->options_.plotly_js, &made->page_));
  made->Route();
  KCRIG_RETURN_IF_ERROR(made->Listen(host, port));
  made->thread_ = std::thread([c = made.get()] { c->Serve(); });
  *console = std::move(made);
  return Status::Ok();
}

Status LiveConsole::Listen(const std::string& host, int port) {
  httplib::Server& s = *server_;
  s.set_read_timeout(kIoTimeoutSeconds, 0);
  s.set_write_timeout(kIoTimeoutSeconds, 0);
  s.set_keep_alive_timeout(kIoTimeoutSeconds);
  s.set_payload_max_length(kMaxRequestBytes);
  const int threads = options_.max_viewers + kSpareWorkers;
  s.new_task_queue = [threads, cpu = options_.loop_cpu] {
    return new ConsoleWorkers(threads, cpu);
  };
  int listening = -1;
  s.set_socket_options([&listening](int sock) {
    listening = sock;
    const int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
    setsockopt(sock, SOL_SOCKET, SO_SNDBUF, &kSendBufferBytes,
               sizeof(kSendBufferBytes));
  });
  errno = 0;
  const int bound = port == 0 ? s.bind_to_any_port(host)
                              : (s.bind_to_port(host, port) ? port : -1);
  s.set_socket_options(httplib::default_socket_options);
  // The library listens with a backlog of 5: a burst of connections (a
  // page and its stream from a few browsers, or junk) would be refused.
  if (bound > 0 && listening >= 0) listen(listening, kListenBacklog);
  if (bound <= 0) {
    return Status::Error(
        "--console " + options_.address + ": cannot listen there (" +
        (errno != 0 ? std::strerror(errno) : "bind failed") + ")");
  }
  url_ = "http://" + UrlHost(host) + ":" + std::to_string(bound) +
         "/?token=" + token_;
  return Status::Ok();
}

void LiveConsole::Serve() {
  BelowTheLoop(options_.loop_cpu);
  if (!server_->listen_after_bind() && !stopping_ && options_.on_failure) {
    options_.on_failure("the console stopped serving; the run goes on");
  }
}

void LiveConsole::Route() {
  using httplib::Request;
  using httplib::Response;
  httplib::Server& s = *server_;
  s.set_pre_routing_handler([this](const Request& req, Response& res) {
    const std::string given = req.has_header("X-Kcrig-Token")
                                  ? req.get_header_value("X-Kcrig-Token")
                                  : req.get_param_value("token");
    if (SameToken(given, token_)) {
      return httplib::Server::HandlerResponse::Unhandled;
    }
    res.status = 403;
    res.set_content(
        "kcrig console: refused without the token of the URL kcrig "
        "printed\n",
        "text/plain");
    return httplib::Server::HandlerResponse::Handled;
  });
  s.set_post_routing_handler([](const Request&, Response& res) {
    res.set_header("Cache-Control", "no-store");
    res.set_header("X-Content-Type-Options", "nosniff");
    res.set_header("Referrer-Policy", "no-referrer");
  });
  s.Get("/", [this](const Request&, Response& res) {
    // Scripts and styles inline only, connections to this console only.
    res.set_header("Content-Security-Policy",
                   "default-src 'none'; script-src 'unsafe-inline' "
                   "'unsafe-eval'; style-src 'unsafe-inline'; img-src data: "
                   "blob:; font-src data:; connect-src 'self'; base-uri "
                   "'none'; form-action 'none'; frame-ancestors 'none'");
    // Through a provider of known length: served as it is, never
    // recompressed per request (brotli takes seconds over 8 MB).
    res.set_content_provider(page_.size(), "text/html; charset=utf-8",
                             [this](std::size_t offset, std::size_t length,
                                    httplib::DataSink& sink) {
                               return sink.write(
                                   page_.data() + offset,
                                   std::min(length, page_.size() - offset));
                             });
  });
  s.Post("/stop", [this](const Request& req, Response& res) {
    if (!stop_requested_.exchange(true)) {
      feed_.Note("operator stop from the console (" + req.remote_addr +
                 "): ramping down");
      if (options_.on_stop) options_.on_stop();
    }
    res.set_content("{\"stopping\":true}\n", "application/json");
  });
  s.Get("/events", [this](const Request&, Response& res) {
    if (viewers_.fetch_add(1) >= options_.max_viewers) {
      viewers_.fetch_sub(1);
      res.status = 503;
      res.set_content("kcrig console: too many viewers\n", "text/plain");
      return;
    }
    struct Cursor {
      bool started = false;
      std::uint64_t seq = 0;
      std::chrono::steady_clock::time_point written =
          std::chrono::steady_clock::now();
    };
    auto cursor = std::make_shared<Cursor>();
    res.set_chunked_content_provider(
        "text/event-stream",
        [this, cursor](std::size_t, httplib::DataSink& sink) {
          std::string out;
          if (!cursor->started) {
            out = feed_.Snapshot(&cursor->seq);
            cursor->started = true;
          }
          const LiveFeed::Read read = feed_.ReadAfter(
              &cursor->seq, &out, std::chrono::milliseconds(250));
          if (read == LiveFeed::Read::kStalled) return false;
          const auto now = std::chrono::steady_clock::now();
          if (out.empty() && now - cursor->written >= kKeepAlive) {
            out = ":\n\n";
          }
          if (!out.empty()) {
            if (!sink.write(out.data(), out.size())) return false;
            cursor->written = now;
          }
          if (read == LiveFeed::Read::kEnded) sink.done();
          return true;
        },
        [this](bool) { viewers_.fetch_sub(1); });
  });
}

void LiveConsole::Shutdown(const std::string& outcome) {
  if (ending_.exchange(true)) return;
  // Every stream sends the end and closes itself; one that cannot within
  // the write timeout is cut.
  feed_.End(outcome);
  const auto until = std::chrono::steady_clock::now() +
                     std::chrono::seconds(kIoTimeoutSeconds);
  while (viewers_.load() > 0 && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  stopping_ = true;
  server_->stop();
  if (thread_.joinable()) thread_.join();
}

LiveConsole::~LiveConsole() { Shutdown("kcrig ended"); }

}  // namespace kcrig
