#include "records/partial_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

namespace kcrig {

PartialFile::~PartialFile() {
  if (fd_ >= 0) close(fd_);
}

Status PartialFile::Open(const std::string& path) {
  path_ = path;
  partial_path_ = path + ".partial";
  failed_ = false;
  error_.clear();
  size_ = 0;
  KCRIG_RETURN_IF_ERROR(CheckReplaceable(path_));
  KCRIG_RETURN_IF_ERROR(CheckReplaceable(partial_path_));
  std::error_code ignored;  // open says what went wrong
  std::filesystem::create_directories(std::filesystem::path(path).parent_path(),
                                      ignored);
  fd_ = open(partial_path_.c_str(),
             O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC | O_NOFOLLOW, 0644);
  if (fd_ < 0) {
    return Status::Error(partial_path_ + ": cannot write (" +
                         std::strerror(errno) + ")");
  }
  return Status::Ok();
}

bool PartialFile::Write(std::string_view bytes) {
  if (fd_ < 0) return false;
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = write(fd_, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      if (error_.empty()) error_ = n < 0 ? std::strerror(errno) : "no progress";
      failed_ = true;
      // Back to the end of the last whole write.
      if (ftruncate(fd_, static_cast<off_t>(size_)) == 0) {
        lseek(fd_, static_cast<off_t>(size_), SEEK_SET);
      }
      return false;
    }
    done += static_cast<size_t>(n);
  }
  size_ += bytes.size();
  return true;
}

Status PartialFile::Close() {
  if (fd_ < 0) return Status::Ok();
  failed_ |= close(fd_) != 0;
  fd_ = -1;
  if (failed_) {
    return Status::Error(partial_path_ + ": writing failed (" +
                         (error_.empty() ? "disk full?" : error_) +
                         "); what was written so far is in this file");
  }
  return Status::Ok();
}

Status PartialFile::Commit() {
  KCRIG_RETURN_IF_ERROR(Close());
  if (std::rename(partial_path_.c_str(), path_.c_str()) != 0) {
    return Status::Error(path_ + ": cannot rename " + partial_path_ +
                         " into place (" + std::strerror(errno) + ")");
  }
  return Status::Ok();
}

void PartialFile::Discard() {
  if (fd_ < 0) return;
  close(fd_);
  fd_ = -1;
  std::remove(partial_path_.c_str());
}

}  // namespace kcrig
