// The processes a batch of independent items (the cases of `kcrig
// validate`) is spread over: MPI's world when kcrig was built with MPI and
// launched by mpirun (or srun), else this process alone. Items go to
// whichever rank is free (ForEachItem), and the root (rank 0) gathers every
// item's result in item order: what it writes is the same for any number of
// ranks.
#ifndef KCRIG_CLUSTER_RANKS_H_
#define KCRIG_CLUSTER_RANKS_H_

#include <functional>
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

  // Started by an MPI launcher with several ranks but built without MPI:
  // why kcrig cannot run so ("" otherwise). main refuses to go on.
  const std::string& launch_error() const { return launch_error_; }

  int rank() const { return rank_; }
  int size() const { return size_; }
  bool is_root() const { return rank_ == 0; }

  // work(item) for items 0 .. count-1 spread over the ranks, each rank
  // taking the next item when it finishes one (rank 0 hands them out, from
  // a thread of its own, while it works too), so that items of uneven cost
  // balance. Which rank ran an item is not part of any result: Gather puts
  // them in item order. `work` returns false to take no more items on this
  // rank. Collective.
  void ForEachItem(int count, const std::function<bool(int)>& work) const;

  // Every rank's `local` status agreed on: an error of any rank (the
  // lowest failing one, named) is every rank's, so that all stop together
  // instead of some waiting in a collective for ranks that left. Call it
  // after what a rank checks alone (its inputs, the root's output file).
  // Collective.
  Status Agree(const Status& local) const;

  // Sends this rank's stdout and stderr to /dev/null (rank 0 alone prints),
  // keeping stderr for AbortJob's one line.
  void SilenceOutput();

  // Ends the whole job with `code` (MPI_Abort; std::exit alone) after one
  // line, `why` (none when empty), on this rank's stderr (also when
  // silenced): for an error
  // one rank met alone while the others may wait in a collective.
  [[noreturn]] void AbortJob(int code, const std::string& why) const;

  // The root's `bytes` and status on every rank (the other ranks' inputs
  // are ignored): what the root alone may produce, such as a rig's log, for
  // every rank to go on from. Collective.
  Status Share(const Status& root_status, std::string* bytes) const;

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
  int kept_stderr_ = -1;  // the stderr SilenceOutput replaced
  std::string launch_error_;
};

// The process's ranks: main's Ranks, or rank 0 of 1 when there is none.
const Ranks& WorldRanks();

// Batches spread over WorldRanks(): job j runs on rank j mod N (on up to
// `threads` threads there) and every rank receives every result. One rank:
// the local threads alone.
const BatchRunner& WorldBatches();

}  // namespace kcrig

#endif  // KCRIG_CLUSTER_RANKS_H_
