#include "cluster/ranks.h"

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>

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

// Merges the ranks' payloads (index = rank) into `all`.
Status Merge(int num_items, const std::vector<std::string>& payloads,
             std::vector<std::string>* all) {
  all->assign(num_items, std::string());
  std::vector<bool> seen(num_items, false);
  for (size_t rank = 0; rank < payloads.size(); ++rank) {
    const std::string who = "rank " + std::to_string(rank) + ": ";
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

}  // namespace

Ranks::Ranks(int* argc, char*** argv) {
#ifdef KCRIG_WITH_MPI
  if (LaunchedByMpi()) {
    MPI_Init(argc, argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
    joined_mpi_ = true;
  }
#else
  (void)argc;
  (void)argv;
#endif
  world = this;
}

Ranks::~Ranks() {
#ifdef KCRIG_WITH_MPI
  if (joined_mpi_) MPI_Finalize();
#endif
  if (world == this) world = nullptr;
}

Status Ranks::Broadcast(const Status& status) const {
#ifdef KCRIG_WITH_MPI
  if (joined_mpi_) {
    std::string message = status.ok() ? "" : status.message();
    int length = static_cast<int>(message.size());
    int failed = status.ok() ? 0 : 1;
    MPI_Bcast(&failed, 1, MPI_INT, 0, MPI_COMM_WORLD);
    MPI_Bcast(&length, 1, MPI_INT, 0, MPI_COMM_WORLD);
    message.resize(length);
    MPI_Bcast(message.data(), length, MPI_CHAR, 0, MPI_COMM_WORLD);
    return failed ? Status::Error(message) : Status::Ok();
  }
#endif
  return status;
}

Status Ranks::Gather(int num_items, const Status& local,
                     const std::map<int, std::string>& mine,
                     std::vector<std::string>* all) const {
  const std::string payload = Payload(local, mine);
  std::vector<std::string> payloads = {payload};
#ifdef KCRIG_WITH_MPI
  if (joined_mpi_) {
    int length = static_cast<int>(payload.size());
    std::vector<int> lengths(size_), offsets(size_);
    MPI_Gather(&length, 1, MPI_INT, lengths.data(), 1, MPI_INT, 0,
               MPI_COMM_WORLD);
    std::string received;
    if (is_root()) {
      long total = 0;
      for (int r = 0; r < size_; ++r) {
        offsets[r] = static_cast<int>(total);
        total += lengths[r];
      }
      received.resize(total);
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

// Jobs of the batch on rank r: r, r + N, ...; their results gathered by
// every rank (MPI_Allgatherv of each rank's packed results).
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
    results->assign(count, std::string());
    std::string packed;
    for (const std::string& result : mine) {
      const std::uint64_t length = result.size();
      packed.append(reinterpret_cast<const char*>(&length), sizeof(length));
      packed += result;
    }
    std::string all;
    std::vector<int> lengths, offsets;
    AllGather(packed, &all, &lengths, &offsets);
    for (int rank = 0; rank < ranks.size(); ++rank) {
      size_t at = offsets[rank];
      for (int j = rank; j < count; j += ranks.size()) {
        std::uint64_t length = 0;
        std::memcpy(&length, all.data() + at, sizeof(length));
        at += sizeof(length);
        (*results)[j] = all.substr(at, length);
        at += length;
      }
    }
  }

 private:
  // Every rank's `mine`, concatenated in rank order, on every rank.
  static void AllGather(const std::string& mine, std::string* all,
                        std::vector<int>* lengths, std::vector<int>* offsets) {
    const int size = WorldRanks().size();
    lengths->assign(size, 0);
    offsets->assign(size, 0);
#ifdef KCRIG_WITH_MPI
    int length = static_cast<int>(mine.size());
    MPI_Allgather(&length, 1, MPI_INT, lengths->data(), 1, MPI_INT,
                  MPI_COMM_WORLD);
    long total = 0;
    for (int r = 0; r < size; ++r) {
      (*offsets)[r] = static_cast<int>(total);
      total += (*lengths)[r];
    }
    all->resize(total);
    MPI_Allgatherv(mine.data(), length, MPI_CHAR, all->data(), lengths->data(),
                   offsets->data(), MPI_CHAR, MPI_COMM_WORLD);
#else
    (*lengths)[0] = static_cast<int>(mine.size());
    *all = mine;
#endif
  }
};

const BatchRunner& WorldBatches() {
  static const RankBatchRunner spread;
  return WorldRanks().size() > 1 ? static_cast<const BatchRunner&>(spread)
                                 : BatchesOr(nullptr);
}

const Ranks& WorldRanks() {
  static const Ranks alone;
  return world != nullptr ? *world : alone;
}

bool BuiltWithMpi() {
#ifdef KCRIG_WITH_MPI
  return true;
#else
  return false;
#endif
}

}  // namespace kcrig
