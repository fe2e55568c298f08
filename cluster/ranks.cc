#include "cluster/ranks.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <map>
#include <mutex>
#include <numeric>
#include <string>
#include <thread>

#include "base/parallel_for.h"

#ifdef KCRIG_WITH_MPI
#include <mpi.h>
#endif

namespace kcrig {
namespace {

const Ranks* world = nullptr;

// Open MPI's mpirun, PMIx (srun, prterun) and MPICH's Hydra set these; a
// plain start sets none, and then MPI is not joined (a singleton MPI_Init
// would start a daemon for nothing).
bool LaunchedByMpi() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK"}) {
    if (std::getenv(name) != nullptr) return true;
  }
  return false;
}

#ifndef KCRIG_WITH_MPI
// The world size the launcher announces (1 when it says nothing).
int AnnouncedSize() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"}) {
    if (const char* value = std::getenv(name)) return std::atoi(value);
  }
  return 1;
}
#endif

// The root's view of a batch: the items left, what each kind of item has
// cost so far, the results and the first error. Shared by the root's
// workers and its dispatcher.
class ItemQueue {
 public:
  ItemQueue(const std::vector<int>& pending, const std::vector<int>& kinds,
            const Ranks::ItemDone& done, std::vector<std::string>* results)
      : kinds_(kinds),
        done_(done),
        results_(results),
        state_(results->size(), kWaiting) {
    for (int position = 0; position < static_cast<int>(pending.size());
         ++position) {
      const int item = pending[position];
      // An item outside the batch fails it; every worker is still answered.
      if (item < 0 || item >= static_cast<int>(state_.size())) {
        Fail(Status::Error("item " + std::to_string(item) +
                           " is not in the batch"));
      }
      left_[Kind(item)].emplace_back(position, item);
    }
  }

  // The next item to run, or -1 when none is left or the batch failed.
  int Next() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!status_.ok()) return -1;
    // Each kind's items in their batch order: the next one of the kind
    // expected to take longest (ties: the kind first in the batch).
    std::deque<Pending>* best = nullptr;
    double best_cost = -HUGE_VAL;
    for (auto& [kind, items] : left_) {
      const double cost = Expected(kind);
      if (!items.empty() &&
          (best == nullptr || cost > best_cost ||
           (cost == best_cost && items.front() < best->front()))) {
        best = &items;
        best_cost = cost;
      }
    }
    if (best == nullptr) return -1;
    const int item = best->front().second;
    best->pop_front();
    if (item >= 0 && item < static_cast<int>(state_.size())) {
      state_[item] = kRunning;
    }
    return item;
  }

  // The outcome of `item` as `who` ("" or "rank N: ") reports it.
  void Finish(int item, const Status& status, std::string result,
              double seconds, const std::string& who) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!status.ok()) return Fail(Status::Error(who + status.message()));
    if (item < 0 || item >= static_cast<int>(state_.size()) ||
        state_[item] != kRunning) {
      return Fail(Status::Error(who + "returned item " + std::to_string(item) +
                                " that it was not given"));
    }
    state_[item] = kDone;
    (*results_)[item] = std::move(result);
    Cost& cost = costs_[Kind(item)];
    cost.seconds += seconds;
    ++cost.items;
    if (done_) {
      const Status recorded = done_(item, (*results_)[item], seconds);
      if (!recorded.ok()) Fail(recorded);
    }
  }

  Status status() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return status_;
  }

 private:
  enum State : char { kWaiting, kRunning, kDone };
  struct Cost {
    double seconds = 0;
    int items = 0;
  };

  int Kind(int item) const {
    return item >= 0 && item < static_cast<int>(kinds_.size()) ? kinds_[item]
                                                               : 0;
  }
  // The mean cost of a kind's items so far; a kind not yet measured first
  // (its items may be the slow ones).
  double Expected(int kind) const {
    const auto cost = costs_.find(kind);
    if (cost == costs_.end()) return HUGE_VAL;
    return cost->second.seconds / cost->second.items;
  }
  void Fail(const Status& status) {
    if (status_.ok()) status_ = status;
  }

  mutable std::mutex mutex_;
  // (position in the batch, item): each kind's items left, in batch order.
  using Pending = std::pair<int, int>;
  std::map<int, std::deque<Pending>> left_;
  const std::vector<int>& kinds_;
  const Ranks::ItemDone& done_;
  std::vector<std::string>* results_;
  std::vector<State> state_;
  std::map<int, Cost> costs_;
  Status status_;
};

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
      .count();
}

// The root's `threads` workers: each takes the queue's next item until
// none is left.
void WorkOnRoot(ItemQueue* queue, int threads, const Ranks::ItemWork& work,
                const std::string& who) {
  ParallelFor(threads, threads, [&](int) {
    for (int item = queue->Next(); item >= 0; item = queue->Next()) {
      const auto start = std::chrono::steady_clock::now();
      std::string result;
      const Status status = work(item, &result);
      queue->Finish(item, status, std::move(result), SecondsSince(start), who);
      if (!status.ok()) return;
    }
  });
}

}  // namespace

Ranks::Ranks(int* argc, char*** argv) {
  world = this;
  if (!LaunchedByMpi()) return;
#ifdef KCRIG_WITH_MPI
  // One thread calls MPI at a time: rank 0's dispatcher (Distribute) while
  // its workers compute without MPI, the other ranks' workers under a lock.
  int provided = 0;
  MPI_Init_thread(argc, argv, MPI_THREAD_SERIALIZED, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
  joined_mpi_ = true;
  if (provided < MPI_THREAD_SERIALIZED && size_ > 1) {
    launch_error_ =
        "this MPI library gives no thread support (kcrig needs "
        "MPI_THREAD_SERIALIZED)";
  }
#else
  (void)argc;
  (void)argv;
  if (AnnouncedSize() > 1) {
    launch_error_ =
        "this kcrig was built without MPI: start it without mpirun (or "
        "build it with libopenmpi-dev installed)";
  }
#endif
}

Ranks::~Ranks() {
#ifdef KCRIG_WITH_MPI
  if (joined_mpi_) MPI_Finalize();
#endif
  if (world == this) world = nullptr;
}

Status Ranks::Agree(const Status& local) const {
#ifdef KCRIG_WITH_MPI
  if (joined_mpi_ && size_ > 1) {
    // The lowest failing rank (size_: none) tells every rank its error.
    int failing = local.ok() ? size_ : rank_;
    MPI_Allreduce(MPI_IN_PLACE, &failing, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (failing == size_) return Status::Ok();
    std::string message = local.ok() ? "" : local.message();
    int length = static_cast<int>(message.size());
    MPI_Bcast(&length, 1, MPI_INT, failing, MPI_COMM_WORLD);
    message.resize(length);
    MPI_Bcast(message.data(), length, MPI_CHAR, failing, MPI_COMM_WORLD);
    return Status::Error("rank " + std::to_string(failing) + ": " + message);
  }
#endif
  return local;
}

void Ranks::SilenceOutput() {
  std::fflush(stderr);
  kept_stderr_ = dup(STDERR_FILENO);
  (void)std::freopen("/dev/null", "w", stdout);
  (void)std::freopen("/dev/null", "w", stderr);
}

void Ranks::AbortJob(int code, const std::string& why) const {
  std::fflush(stdout);
  const std::string line = why.empty() ? "" : why + "\n";
  if (kept_stderr_ >= 0) {
    (void)!write(kept_stderr_, line.data(), line.size());
  } else {
    std::fputs(line.c_str(), stderr);
  }
  std::fflush(stderr);
#ifdef KCRIG_WITH_MPI
  if (joined_mpi_) MPI_Abort(MPI_COMM_WORLD, code);
#endif
  std::exit(code);
}

Status Ranks::Share(const Status& root_status, std::string* bytes) const {
#ifdef KCRIG_WITH_MPI
  if (joined_mpi_ && size_ > 1) {
    std::string message = root_status.ok() ? "" : root_status.message();
    const std::string& payload = root_status.ok() ? *bytes : message;
    // ok flag and length; a payload beyond MPI's int counts ends the job.
    long header[2] = {root_status.ok() ? 1 : 0,
                      static_cast<long>(payload.size())};
    MPI_Bcast(header, 2, MPI_LONG, 0, MPI_COMM_WORLD);
    if (header[1] > INT_MAX) {
      if (is_root())
        std::fprintf(stderr, "kcrig: a shared file exceeds 2 GiB\n");
      MPI_Abort(MPI_COMM_WORLD, 1);
    }
    std::string received = is_root() ? payload : std::string(header[1], '\0');
    MPI_Bcast(received.data(), static_cast<int>(header[1]), MPI_CHAR, 0,
              MPI_COMM_WORLD);
    if (is_root()) return root_status;
    if (header[0] == 0) return Status::Error("rank 0: " + received);
    *bytes = std::move(received);
    return Status::Ok();
  }
#endif
  return root_status;
}

#ifdef KCRIG_WITH_MPI
namespace {

constexpr int kResultTag = 7101;  // a worker's last outcome, asking for more
constexpr int kItemTag = 7102;    // the item given (-1: none left)

// What a worker thread sends the root: the item it ran (-1: none yet),
// whether it succeeded, its seconds, then its result or error.
struct OutcomeHeader {
  std::int32_t item = -1;
  std::int32_t ok = 1;
  double seconds = 0;
};

std::string EncodeOutcome(int item, const Status& status,
                          const std::string& result, double seconds) {
  const OutcomeHeader header{item, status.ok() ? 1 : 0, seconds};
  std::string message(reinterpret_cast<const char*>(&header), sizeof(header));
  message += status.ok() ? result : status.message();
  if (message.size() > INT_MAX) {
    std::fprintf(stderr, "kcrig: an item's result exceeds 2 GiB\n");
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
  return message;
}

// Receives the next outcome any worker sends (polling: a blocking receive
// would spin a core that the root's own work needs); returns its source.
int ReceiveOutcome(std::string* message) {
  MPI_Status probe;
  for (int arrived = 0;;) {
    MPI_Iprobe(MPI_ANY_SOURCE, kResultTag, MPI_COMM_WORLD, &arrived, &probe);
    if (arrived) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  int length = 0;
  MPI_Get_count(&probe, MPI_CHAR, &length);
  message->assign(static_cast<size_t>(length), '\0');
  MPI_Recv(message->data(), length, MPI_CHAR, probe.MPI_SOURCE, kResultTag,
           MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  return probe.MPI_SOURCE;
}

// The root's dispatcher: takes each worker thread's outcome into the queue
// and answers with its next item, until every worker thread has left.
void Dispatch(int worker_threads, ItemQueue* queue) {
  std::string message;
  while (worker_threads > 0) {
    const int source = ReceiveOutcome(&message);
    const std::string who = "rank " + std::to_string(source) + ": ";
    OutcomeHeader header;  // item -1: nothing to take in
    if (message.size() < sizeof(header)) {
      queue->Finish(-1, Status::Error("unreadable result"), "", 0, who);
    } else {
      std::memcpy(&header, message.data(), sizeof(header));
    }
    std::string body = message.substr(std::min(message.size(), sizeof(header)));
    // A failure stops the batch before its rank is answered; a result is
    // recorded (a checkpoint write) only after its rank has its next item.
    if (header.item >= 0 && !header.ok) {
      queue->Finish(header.item, Status::Error(body), "", 0, who);
    }
    const int next = queue->Next();
    MPI_Send(&next, 1, MPI_INT, source, kItemTag, MPI_COMM_WORLD);
    if (header.item >= 0 && header.ok) {
      queue->Finish(header.item, Status::Ok(), std::move(body), header.seconds,
                    who);
    }
    worker_threads -= next < 0;
  }
}

// A worker rank's `threads` threads: each sends its last outcome, receives
// its next item, runs it, until the root says none is left. One thread
// calls MPI at a time (MPI_THREAD_SERIALIZED). Returns the rank's first
// error.
Status ServeRoot(int threads, const Ranks::ItemWork& work) {
  std::mutex mpi;
  Status first_error;
  ParallelFor(threads, threads, [&](int) {
    std::string outcome = EncodeOutcome(-1, Status::Ok(), "", 0);
    for (;;) {
      int item = -1;
      {
        std::lock_guard<std::mutex> lock(mpi);
        MPI_Send(outcome.data(), static_cast<int>(outcome.size()), MPI_CHAR, 0,
                 kResultTag, MPI_COMM_WORLD);
        MPI_Recv(&item, 1, MPI_INT, 0, kItemTag, MPI_COMM_WORLD,
                 MPI_STATUS_IGNORE);
        if (item < 0) return;
      }
      const auto start = std::chrono::steady_clock::now();
      std::string result;
      const Status status = work(item, &result);
      outcome = EncodeOutcome(item, status, result, SecondsSince(start));
      if (!status.ok()) {
        std::lock_guard<std::mutex> lock(mpi);
        if (first_error.ok()) first_error = status;
      }
    }
  });
  return first_error;
}

}  // namespace
#endif

Status Ranks::Distribute(const std::vector<int>& pending,
                         const std::vector<int>& kinds, int threads,
                         const ItemWork& work, const ItemDone& done,
                         std::vector<std::string>* results) const {
  threads = std::max(1, threads);
#ifdef KCRIG_WITH_MPI
  if (joined_mpi_ && size_ > 1) {
    if (!is_root()) return ServeRoot(threads, work);
    ItemQueue queue(pending, kinds, done, results);
    std::thread dispatcher(Dispatch, (size_ - 1) * threads, &queue);
    WorkOnRoot(&queue, threads, work, "rank 0: ");
    dispatcher.join();
    return queue.status();
  }
#endif
  ItemQueue queue(pending, kinds, done, results);
  WorkOnRoot(&queue, threads, work, "");
  return queue.status();
}

namespace {

// A batch's jobs handed out by Distribute; the root then shares every
// result with every rank (each prefixed with its length).
class RankBatchRunner final : public BatchRunner {
 public:
  void Run(int count, int threads,
           const std::function<void(int, std::string*)>& work,
           std::vector<std::string>* results) const override {
    const Ranks& ranks = WorldRanks();
    std::vector<int> jobs(static_cast<size_t>(std::max(count, 0)));
    std::iota(jobs.begin(), jobs.end(), 0);
    results->assign(jobs.size(), std::string());
    Status status = ranks.Distribute(
        jobs, {}, threads,
        [&](int j, std::string* result) {
          work(j, result);
          return Status::Ok();
        },
        nullptr, results);
    std::string packed = ranks.is_root() ? Pack(*results) : std::string();
    status = ranks.Share(status, &packed);
    if (!ranks.is_root()) Unpack(status.ok() ? packed : "", results);
  }

 private:
  static std::string Pack(const std::vector<std::string>& results) {
    std::string packed;
    for (const std::string& result : results) {
      const std::uint64_t length = result.size();
      packed.append(reinterpret_cast<const char*>(&length), sizeof(length));
      packed += result;
    }
    return packed;
  }

  // The jobs' results in order; what `packed` does not hold whole stays
  // empty (the callers' decoders refuse an empty result).
  static void Unpack(const std::string& packed,
                     std::vector<std::string>* results) {
    size_t at = 0;
    for (std::string& result : *results) {
      std::uint64_t length = 0;
      if (packed.size() - at < sizeof(length)) break;
      std::memcpy(&length, packed.data() + at, sizeof(length));
      at += sizeof(length);
      if (length > packed.size() - at) break;
      result = packed.substr(at, length);
      at += length;
    }
  }
};

}  // namespace

const BatchRunner& WorldBatches() {
  static const RankBatchRunner spread;
  return WorldRanks().size() > 1 ? static_cast<const BatchRunner&>(spread)
                                 : BatchesOr(nullptr);
}

int ThreadsPerRank(const Ranks& ranks, std::optional<int> requested) {
  if (requested) return *requested;
  return ranks.size() > 1 ? 1 : kDefaultThreads;
}

const Ranks& WorldRanks() {
  static const Ranks alone;
  return world != nullptr ? *world : alone;
}

}  // namespace kcrig
