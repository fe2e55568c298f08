// The processes a batch of independent items (the cases of `kcrig
// validate`) is spread over: MPI's world when kcrig was built with MPI and
// launched by mpirun (or srun), else this process alone. Item i belongs to
// rank i % size, and the root (rank 0) gathers every item's result in item
// order: what it writes is the same for any number of ranks.
#ifndef KCRIG_CLUSTER_RANKS_H_
#define KCRIG_CLUSTER_RANKS_H_

#include <map>
#include <string>
#include <vector>

#include "base/batch_runner.h"
#include "base/status.h"

namespace kcrig {

class Ranks {
 public:
  // Joins MPI when the environment says an MPI launcher started this
  // process, else is rank 0 of 1; leaves MPI on destruction. One per
  // process, owned by main (WorldRanks() then returns it).
  Ranks(int* argc, char*** argv);
  // This process alone, without MPI.
  Ranks() = default;
  ~Ranks();
  Ranks(const Ranks&) = delete;
  Ranks& operator=(const Ranks&) = delete;

  int rank() const { return rank_; }
  int size() const { return size_; }
  bool is_root() const { return rank_ == 0; }
  bool Owns(int item) const { return item % size_ == rank_; }

  // The root's `status` on every rank (what only the root checks, such as
  // its output file, stops all ranks alike). Collective.
  Status Broadcast(const Status& status) const;

  // Every rank passes the results of its own items (item -> text) or the
  // error that stopped it; the root receives the texts of items
  // 0 .. num_items-1 in order. On the root, an error of any rank is
  // returned naming that rank ("rank 2: ..."); the other ranks return their
  // own status and receive nothing. Collective: every rank calls it once.
  Status Gather(int num_items, const Status& local,
                const std::map<int, std::string>& mine,
                std::vector<std::string>* all) const;

 private:
  int rank_ = 0;
  int size_ = 1;
  bool joined_mpi_ = false;
};

// The process's ranks: main's Ranks, or rank 0 of 1 when there is none.
const Ranks& WorldRanks();

// Batches spread over WorldRanks(): job j runs on rank j mod N (on up to
// `threads` threads there) and every rank receives every result. One rank:
// the local threads alone.
const BatchRunner& WorldBatches();

// Whether this kcrig was built with MPI.
bool BuiltWithMpi();

}  // namespace kcrig

#endif  // KCRIG_CLUSTER_RANKS_H_
