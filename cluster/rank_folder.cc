#include "cluster/rank_folder.h"

#include <unistd.h>

#include <filesystem>
#include <system_error>

namespace kcrig {

RankFolder::RankFolder(const std::string& what, int rank) {
  std::error_code error;
  const std::filesystem::path temp =
      std::filesystem::temp_directory_path(error);
  if (error) {
    status_ = Status::Error("no temporary folder (" + error.message() + ")");
    return;
  }
  path_ = (temp / ("kcrig_" + what + "_rank" + std::to_string(rank) + "_" +
                   std::to_string(getpid())))
              .string();
}

void RankFolder::Remove() const {
  std::error_code ignored;
  if (!path_.empty()) std::filesystem::remove_all(path_, ignored);
}

}  // namespace kcrig
