#include "base/atomic_files.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <set>

namespace kcrig {

Status CheckReplaceable(const std::string& path) {
  std::error_code error;
  const std::filesystem::file_status status =
      std::filesystem::symlink_status(path, error);
  if (error && error != std::errc::no_such_file_or_directory) {
    return Status::Error(path + ": cannot inspect (" + error.message() + ")");
  }
  if (!std::filesystem::exists(status) ||
      std::filesystem::is_regular_file(status)) {
    return Status::Ok();
  }
  const char* what = std::filesystem::is_symlink(status) ? "a symbolic link"
                     : std::filesystem::is_directory(status)
                         ? "a directory"
                         : "a device or FIFO";
  return Status::Error(path + ": is " + what +
                       ", not a regular file; kcrig never replaces it");
}

namespace {

// The file's bytes on the disk; a file system that cannot sync (some FUSE
// or 9p mounts) is taken as it is.
bool Synced(int fd) {
  return fsync(fd) == 0 || errno == EINVAL || errno == ENOSYS ||
         errno == EOPNOTSUPP;
}

// The renames on the disk too (best effort: not every file system syncs a
// folder).
void SyncParentFolders(
    const std::vector<std::pair<std::string, std::string>>& files) {
  for (const auto& file : files) {
    std::string parent = std::filesystem::path(file.first).parent_path();
    if (parent.empty()) parent = ".";
    const int folder = open(parent.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (folder < 0) continue;
    (void)fsync(folder);
    close(folder);
  }
}

}  // namespace

Status WriteFilesAtomically(
    const std::vector<std::pair<std::string, std::string>>& files) {
  // Two contents for one path would share one temporary.
  std::set<std::string> paths;
  for (const auto& file : files) {
    if (!paths.insert(file.first).second) {
      return Status::Error(file.first + ": given twice to be written");
    }
    KCRIG_RETURN_IF_ERROR(CheckReplaceable(file.first));
  }
  std::vector<std::string> temporaries;
  auto remove_temporaries = [&temporaries] {
    for (const std::string& t : temporaries) std::remove(t.c_str());
  };
  for (const auto& [path, content] : files) {
    const std::string temporary =
        path + ".tmp." + std::to_string(static_cast<long>(getpid()));
    // Never through a link planted at the temporary's name.
    std::remove(temporary.c_str());
    const int fd =
        open(temporary.c_str(),
             O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
    std::FILE* file = fd >= 0 ? fdopen(fd, "wb") : nullptr;
    if (file == nullptr) {
      if (fd >= 0) close(fd);
      const std::string reason = std::strerror(errno);
      remove_temporaries();
      return Status::Error(path + ": cannot write: " + reason);
    }
    temporaries.push_back(temporary);
    // On the disk before the rename: a node that loses power right after
    // leaves the old file or the whole new one, never an empty one.
    const bool written = std::fwrite(content.data(), 1, content.size(), file) ==
                             content.size() &&
                         std::fflush(file) == 0 && Synced(fd);
    int error = written ? 0 : errno;
    const bool closed = std::fclose(file) == 0;
    if (!closed && written) error = errno;
    if (!written || !closed) {
      const std::string reason = std::strerror(error);
      remove_temporaries();
      return Status::Error(path + ": write failed: " + reason);
    }
  }
  for (size_t i = 0; i < files.size(); ++i) {
    if (std::rename(temporaries[i].c_str(), files[i].first.c_str()) != 0) {
      const std::string reason = std::strerror(errno);
      for (size_t k = 0; k < i; ++k) std::remove(files[k].first.c_str());
      remove_temporaries();
      return Status::Error(files[i].first + ": cannot write: " + reason);
    }
  }
  SyncParentFolders(files);
  return Status::Ok();
}

}  // namespace kcrig
