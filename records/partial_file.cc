#include "records/partial_file.h"

#include <cerrno>
#include <cstring>
#include <filesystem>

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

PartialFile::~PartialFile() {
  if (file_ != nullptr) std::fclose(file_);
}

Status PartialFile::Open(const std::string& path) {
  path_ = path;
  partial_path_ = path + ".partial";
  failed_ = false;
  KCRIG_RETURN_IF_ERROR(CheckReplaceable(path_));
  KCRIG_RETURN_IF_ERROR(CheckReplaceable(partial_path_));
  std::error_code ignored;  // fopen says what went wrong
  std::filesystem::create_directories(std::filesystem::path(path).parent_path(),
                                      ignored);
  file_ = std::fopen(partial_path_.c_str(), "wb");
  if (file_ == nullptr) {
    return Status::Error(partial_path_ + ": cannot write (" +
                         std::strerror(errno) + ")");
  }
  return Status::Ok();
}

void PartialFile::Write(std::string_view bytes) {
  if (file_ == nullptr || bytes.empty()) return;
  failed_ |= std::fwrite(bytes.data(), 1, bytes.size(), file_) != bytes.size();
}

void PartialFile::Flush() {
  if (file_ != nullptr) failed_ |= std::fflush(file_) != 0;
}

Status PartialFile::Close() {
  if (file_ == nullptr) return Status::Ok();
  failed_ |= std::fclose(file_) != 0;
  file_ = nullptr;
  if (failed_) {
    return Status::Error(partial_path_ +
                         ": writing failed (disk full?); what was written "
                         "so far is in this file");
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
  if (file_ == nullptr) return;
  std::fclose(file_);
  file_ = nullptr;
  std::remove(partial_path_.c_str());
}

}  // namespace kcrig
