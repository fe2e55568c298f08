// A long batch's completed items kept on disk as they finish, so that a job
// its scheduler killed (a wall-time limit, preemption, a lost node) goes on
// where it stopped instead of starting over (`kcrig validate --resume`, a
// Slurm requeue). The folder holds identity.json, what the batch is (the
// command, kcrig's version, digests of its inputs, the options that shape
// its results), and one item-NNNNNN.json per completed item with its result
// and the seconds it took. Every file is written atomically: a killed job
// leaves whole items or none, and a resumed batch's output is byte for byte
// that of an uninterrupted one.
#ifndef KCRIG_RECORDS_BATCH_CHECKPOINT_H_
#define KCRIG_RECORDS_BATCH_CHECKPOINT_H_

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "base/status.h"

namespace kcrig {

class BatchCheckpoint {
 public:
  // Key and value: what one input or option of the batch is.
  using Identity = std::vector<std::pair<std::string, std::string>>;
  struct Item {
    std::string result;
    double seconds = 0;  // wall time of the item when it ran
  };

  BatchCheckpoint() = default;
  ~BatchCheckpoint();  // lets another job open the folder
  BatchCheckpoint(const BatchCheckpoint&) = delete;
  BatchCheckpoint& operator=(const BatchCheckpoint&) = delete;

  // Opens the checkpoint folder `folder` of the batch `identity` (kcrig's
  // version is added to it) of `count` items. Without `resume` an existing
  // folder is refused (an earlier job's work is never overwritten); with
  // it, an existing folder must hold the same identity (else one line
  // naming the first key that differs) and its items are read, and a
  // missing one is started (so that a requeued job runs the same command
  // line as the first). The folder stays locked (flock) while this object
  // lives: a second job resuming it at once is refused.
  Status Open(const std::string& folder, Identity identity, int count,
              bool resume);

  const std::string& folder() const { return folder_; }
  // The items completed by earlier jobs (by item).
  const std::map<int, Item>& items() const { return items_; }

  // Keeps item `item`'s result (atomically).
  Status Record(int item, const std::string& result, double seconds);

  // Removes the folder once the batch's output is written (nothing when
  // the checkpoint was never opened).
  Status Remove();

 private:
  Status Create();
  Status Lock();
  Status Resume();
  Status ReadItem(const std::string& path, int item);

  std::string folder_;
  Identity identity_;
  int count_ = 0;
  std::map<int, Item> items_;
  int lock_fd_ = -1;
};

// FNV-1a (base/fnv1a.h) of a regular file's bytes, or of a
// folder's regular files (their names and bytes, in name order): what a
// checkpoint compares to know its inputs unchanged. "" when unreadable.
std::string InputDigest(const std::string& path);

}  // namespace kcrig

#endif  // KCRIG_RECORDS_BATCH_CHECKPOINT_H_
