// The processes a batch of independent items (the cases of `kcrig
// validate`, a diagnosis' candidate fits) is spread over: MPI's world when
// kcrig was built with MPI and launched by mpirun (or srun), else this
// process alone. Items go to whichever rank is free (Distribute), and the
// root (rank 0) receives every item's result as it is done, kept by item:
// what it writes is the same for any number of ranks and any schedule.
#ifndef KCRIG_CLUSTER_RANKS_H_
#define KCRIG_CLUSTER_RANKS_H_

#include <functional>
#include <optional>
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

  // A rank's part of a batch: runs one item, writing its result; an error
  // stops the batch (no rank is given another item).
  using ItemWork = std::function<Status(int item, std::string* result)>;
  // Called on the root for each result as it arrives, one at a time (from
  // whichever of the root's threads received it), with the seconds the
  // item took; an error stops the batch.
  using ItemDone = std::function<Status(int item, const std::string& result,
                                        double seconds)>;

  // work(item) for every item of `pending` on `threads` threads per rank,
  // handed out by the root (from a thread of its own, while it works too)
  // to whichever thread of whichever rank is free, so that items of uneven
  // cost balance. `kinds` (one per item of the batch, or empty: all alike)
  // groups items of like cost: the kinds not yet measured go first, then
  // the kind whose items have taken longest (Dakota's idea of adapting to
  // completion speed; the slow items do not come last). Which rank ran an
  // item is in no result: on the root `results` receives them by item
  // (results->size() must cover the items) and the first error of any
  // rank is returned naming it ("rank 2: ..."), the other ranks return
  // their own status. Collective: every rank calls it alike.
  Status Distribute(const std::vector<int>& pending,
                    const std::vector<int>& kinds, int threads,
                    const ItemWork& work, const ItemDone& done,
                    std::vector<std::string>* results) const;

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

 private:
  int rank_ = 0;
  int size_ = 1;
  bool joined_mpi_ = false;
  int kept_stderr_ = -1;  // the stderr SilenceOutput replaced
  std::string launch_error_;
};

// The process's ranks: main's Ranks, or rank 0 of 1 when there is none.
const Ranks& WorldRanks();

// The threads-per-rank policy: `requested` (a --threads) when given, else
// kDefaultThreads in a process alone and one per rank under mpirun (the
// ranks share the cores; one thread also keeps a rank's arithmetic, Ceres'
// sums over threads included, the same as every other rank's).
int ThreadsPerRank(const Ranks& ranks, std::optional<int> requested = {});

// Batches spread over WorldRanks() by Distribute (on up to `threads`
// threads per rank), every rank receiving every result. One rank: the
// local threads alone.
const BatchRunner& WorldBatches();

}  // namespace kcrig

#endif  // KCRIG_CLUSTER_RANKS_H_
