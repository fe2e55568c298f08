// A folder of this process alone in its temporary folder, named for what it
// holds, the rank and the process ("kcrig_inputs_rank1_4242"), removed with
// it: where a rank other than 0 keeps its copies of rank 0's files.
#ifndef KCRIG_CLUSTER_RANK_FOLDER_H_
#define KCRIG_CLUSTER_RANK_FOLDER_H_

#include <string>

#include "base/status.h"

namespace kcrig {

class RankFolder {
 public:
  // `what` names the folder; nothing is created yet. Without a temporary
  // folder, status() says why and path() is empty.
  RankFolder(const std::string& what, int rank);
  ~RankFolder() { Remove(); }
  RankFolder(const RankFolder&) = delete;
  RankFolder& operator=(const RankFolder&) = delete;

  // The same, before the job ends without destructors.
  void Remove() const;
  const std::string& path() const { return path_; }
  const Status& status() const { return status_; }

 private:
  std::string path_;
  Status status_ = Status::Ok();
};

}  // namespace kcrig

#endif  // KCRIG_CLUSTER_RANK_FOLDER_H_
