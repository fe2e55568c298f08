#include "cluster/ranks.h"

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <climits>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>

#include "nlohmann/json.hpp"

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

// One rank's part of a Gather: its status and its items.
std::string Payload(const Status& local,
                    const std::map<int, std::string>& mine) {
  nlohmann::json doc;
  if (!local.ok()) {
    doc["error"] = local.message();
  } else {
    doc["items"] = nlohmann::json::array();
    for (const auto& [item, text] : mine) {
      doc["items"].push_back({item, text});
    }
  }
  return doc.dump();
}

// Merges the ranks' payloads (index = rank) into `all`; an error names its
// rank when there are several.
Status Merge(int num_items, const std::vector<std::string>& payloads,
             std::vector<std::string>* all) {
  all->assign(num_items, std::string());
  std::vector<bool> seen(num_items, false);
  for (size_t rank = 0; rank < payloads.size(); ++rank) {
    const std::string who =
        payloads.size() > 1 ? "rank " + std::to_string(rank) + ": " : "";
    const nlohmann::json doc =
        nlohmann::json::parse(payloads[rank], nullptr, false);
    if (doc.is_discarded()) return Status::Error(who + "unreadable result");
    if (doc.contains("error")) {
      return Status::Error(who + doc["error"].get<std::string>());
    }
    for (const nlohmann::json& entry : doc["items"]) {
      const int item = entry[0].get<int>();
      if (item < 0 || item >= num_items || seen[item]) {
        return Status::Error(who + "item " + std::to_string(item) +
                             " out of range or twice");
      }
      seen[item] = true;
      (*all)[item] = entry[1].get<std::string>();
    }
  }
  for (int item = 0; item < num_items; ++item) {
    if (!seen[item]) {
      return Status::Error("no rank returned item " + std::to_string(item));
    }
  }
  return Status::Ok();
}

#ifdef KCRIG_WITH_MPI
// Offsets of the parts of `lengths` laid end to end; the job ends when
// they exceed what MPI's int counts can address.
std::vector<int> Offsets(const std::vector<int>& lengths) {
  std::vector<int> offsets(lengths.size());
  long total = 0;
  for (size_t r = 0; r < lengths.size(); ++r) {
    offsets[r] = static_cast<int>(total);
    total += lengths[r];
  }
  if (total > INT_MAX) {
    std::fprintf(stderr, "kcrig: a batch's results exceed 2 GiB\n");
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
  return offsets;
}
#endif

}  // namespace

Ranks::Ranks(int* argc, char*** argv) {
  world = this;
  if (!LaunchedByMpi()) return;
#ifdef KCRIG_WITH_MPI
  // The batches' threads never call MPI: only the thread that joined does.
  // Rank 0's dispatcher thread (ForEachItem) calls MPI while the main
  // thread works; the batches' threads never call it.
  int provided = 0;
  MPI_Init_thread(argc, argv, MPI_THREAD_SERIALIZED, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
  joined_mpi_ = true;
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

constexpr int kRequestTag = 7101;  // a worker asks for an item (-1: leaves)
constexpr int kItemTag = 7102;     // the item given (-1: none left)

// Rank 0's dispatcher: answers the other ranks' requests with the next
// item until every one of them has left. Polls (a blocking receive would
// spin a core that rank 0's own work needs).
void Dispatch(int workers, int count, std::atomic<int>* next) {
  while (workers > 0) {
    int request = 0;
    MPI_Request pending;
    MPI_Irecv(&request, 1, MPI_INT, MPI_ANY_SOURCE, kRequestTag, MPI_COMM_WORLD,
              &pending);
    MPI_Status status;
    for (int done = 0; !done;) {
      MPI_Test(&pending, &done, &status);
      if (!done) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    int item = request < 0 ? -1 : (*next)++;
    if (item >= count) item = -1;
    workers -= item < 0;
    MPI_Send(&item, 1, MPI_INT, status.MPI_SOURCE, kItemTag, MPI_COMM_WORLD);
  }
}

}  // namespace
#endif

void Ranks::ForEachItem(int count, const std::function<bool(int)>& work) const {
  if (size_ == 1) {
    for (int item = 0; item < count && work(item); ++item) {
    }
    return;
  }
#ifdef KCRIG_WITH_MPI
  if (is_root()) {
    std::atomic<int> next{0};
    std::thread dispatcher(Dispatch, size_ - 1, count, &next);
    for (int item = next++; item < count && work(item); item = next++) {
    }
    dispatcher.join();
    return;
  }
  for (int request = 0;;) {
    int item = -1;
    MPI_Send(&request, 1, MPI_INT, 0, kRequestTag, MPI_COMM_WORLD);
    MPI_Recv(&item, 1, MPI_INT, 0, kItemTag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    if (item < 0) return;
    if (!work(item)) request = -1;  // leave: the next answer is -1
  }
#endif
}

Status Ranks::Gather(int num_items, const Status& local,
                     const std::map<int, std::string>& mine,
                     std::vector<std::string>* all) const {
  const std::string payload = Payload(local, mine);
  std::vector<std::string> payloads = {payload};
#ifdef KCRIG_WITH_MPI
  if (joined_mpi_) {
    int length = static_cast<int>(payload.size());
    std::vector<int> lengths(size_);
    MPI_Gather(&length, 1, MPI_INT, lengths.data(), 1, MPI_INT, 0,
               MPI_COMM_WORLD);
    std::vector<int> offsets(size_);
    std::string received;
    if (is_root()) {
      offsets = Offsets(lengths);
      received.resize(static_cast<size_t>(offsets.back()) + lengths.back());
    }
    MPI_Gatherv(payload.data(), length, MPI_CHAR, received.data(),
                lengths.data(), offsets.data(), MPI_CHAR, 0, MPI_COMM_WORLD);
    if (!is_root()) return local;
    payloads.clear();
    for (int r = 0; r < size_; ++r) {
      payloads.push_back(received.substr(offsets[r], lengths[r]));
    }
  }
#endif
  return Merge(num_items, payloads, all);
}

namespace {

// Jobs of the batch on rank r: r, r + N, ...; their results gathered by
// every rank (MPI_Allgatherv of each rank's results, each prefixed with its
// length).
class RankBatchRunner final : public BatchRunner {
 public:
  void Run(int count, int threads,
           const std::function<void(int, std::string*)>& work,
           std::vector<std::string>* results) const override {
    const Ranks& ranks = WorldRanks();
    std::vector<int> own;
    for (int j = ranks.rank(); j < count; j += ranks.size()) own.push_back(j);
    std::vector<std::string> mine(own.size());
    ParallelFor(static_cast<int>(own.size()), threads,
                [&](int k) { work(own[k], &mine[k]); });
    std::string packed;
    for (const std::string& result : mine) {
      const std::uint64_t length = result.size();
      packed.append(reinterpret_cast<const char*>(&length), sizeof(length));
      packed += result;
    }
    Unpack(count, AllGather(packed, ranks.size()), results);
  }

 private:
  // Every rank's `mine`, in rank order, on every rank.
  static std::vector<std::string> AllGather(const std::string& mine, int size) {
    std::vector<std::string> parts = {mine};
#ifdef KCRIG_WITH_MPI
    if (size > 1) {
      int length = static_cast<int>(mine.size());
      std::vector<int> lengths(size);
      MPI_Allgather(&length, 1, MPI_INT, lengths.data(), 1, MPI_INT,
                    MPI_COMM_WORLD);
      const std::vector<int> offsets = Offsets(lengths);
      std::string all(static_cast<size_t>(offsets.back()) + lengths.back(),
                      '\0');
      MPI_Allgatherv(mine.data(), length, MPI_CHAR, all.data(), lengths.data(),
                     offsets.data(), MPI_CHAR, MPI_COMM_WORLD);
      parts.clear();
      for (int r = 0; r < size; ++r) {
        parts.push_back(all.substr(offsets[r], lengths[r]));
      }
    }
#else
    (void)size;
#endif
    return parts;
  }

  // Rank r's part holds jobs r, r + N, ... in order; a part that does not
  // hold them whole leaves the rest empty (the callers' decoders refuse an
  // empty result).
  static void Unpack(int count, const std::vector<std::string>& parts,
                     std::vector<std::string>* results) {
    const int size = static_cast<int>(parts.size());
    results->assign(count, std::string());
    for (int rank = 0; rank < size; ++rank) {
      const std::string& part = parts[rank];
      size_t at = 0;
      for (int j = rank; j < count; j += size) {
        std::uint64_t length = 0;
        if (part.size() - at < sizeof(length)) break;
        std::memcpy(&length, part.data() + at, sizeof(length));
        at += sizeof(length);
        if (length > part.size() - at) break;
        (*results)[j] = part.substr(at, length);
        at += length;
      }
    }
  }
};

}  // namespace

const BatchRunner& WorldBatches() {
  static const RankBatchRunner spread;
  return WorldRanks().size() > 1 ? static_cast<const BatchRunner&>(spread)
                                 : BatchesOr(nullptr);
}

const Ranks& WorldRanks() {
  static const Ranks alone;
  return world != nullptr ? *world : alone;
}

}  // namespace kcrig
