#include "cluster/ranks.h"

#include <cstdlib>
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
