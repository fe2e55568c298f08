// Rank 0 alone reads a command's input files: under several MPI ranks the
// root reads each input (a file with its companions, or a folder's regular
// files) and every other rank receives the bytes into a private folder of
// its own and reads its copy, so that a node need not see the root's file
// system. Alone (or on the root) the paths stay as they are.
#ifndef KCRIG_CLUSTER_INPUT_MIRROR_H_
#define KCRIG_CLUSTER_INPUT_MIRROR_H_

#include <memory>
#include <string>
#include <vector>

#include "base/status.h"
#include "cluster/rank_folder.h"
#include "cluster/ranks.h"

namespace kcrig {

class InputMirror {
 public:
  explicit InputMirror(const Ranks& ranks);
  // Removes this rank's copies, before the job ends without destructors
  // (the destructor does too).
  void Remove() const {
    if (folder_) folder_->Remove();
  }
  InputMirror(const InputMirror&) = delete;
  InputMirror& operator=(const InputMirror&) = delete;

  // The file or folder `*path` as the root sees it: on the other ranks
  // `*path` then names the copy. A file's `companions` (e.g. a log's
  // sidecar) that exist on the root are copied beside it under their own
  // names. An empty path (an input not given) stays empty; a path the root
  // cannot read stays as it is (the command's own reading then fails on
  // every rank alike). Collective: every rank calls it with the same
  // arguments in the same order.
  Status Mirror(std::string* path,
                const std::vector<std::string>& companions = {});

 private:
  const Ranks& ranks_;
  // This rank's copies (none on the root and alone).
  std::unique_ptr<RankFolder> folder_;
  int mirrored_ = 0;
};

// Rank 0's files `paths` (a run log and its sidecar that rank 0 alone
// recorded), written at the same paths on every other rank: all in one
// folder, which each rank has as its own. `root_status` is rank 0's outcome
// so far: an error there is every rank's and nothing is shared. Alone it is
// `root_status`. Collective, with InputMirror's codec.
Status ShareFilesInPlace(const Ranks& ranks, Status root_status,
                         const std::vector<std::string>& paths);

}  // namespace kcrig

#endif  // KCRIG_CLUSTER_INPUT_MIRROR_H_
