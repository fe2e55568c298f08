// The one check every reader makes before it reads a file: the path names a
// regular file (a FIFO or a device never ends, a directory cannot be read,
// a symlink loop never resolves) no larger than the reader is built for.
// Never throws.
#ifndef KCRIG_BASE_INPUT_FILE_H_
#define KCRIG_BASE_INPUT_FILE_H_

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "base/status.h"

namespace kcrig {

inline Status CheckInputFile(const std::string& path,
                             std::uintmax_t max_bytes) {
  std::error_code error;
  const std::filesystem::file_status status =
      std::filesystem::status(path, error);
  if (error || !std::filesystem::exists(status)) {
    return Status::Error(path + ": cannot open" +
                         (error ? " (" + error.message() + ")" : ""));
  }
  if (!std::filesystem::is_regular_file(status)) {
    return Status::Error(path + ": not a regular file");
  }
  const std::uintmax_t size = std::filesystem::file_size(path, error);
  if (error) return Status::Error(path + ": cannot open");
  if (size > max_bytes) {
    return Status::Error(path + ": " + std::to_string(size) +
                         " bytes; at most " + std::to_string(max_bytes) +
                         " are read from such a file");
  }
  return Status::Ok();
}

// The whole file, checked as above first.
inline Status ReadInputFile(const std::string& path, std::uintmax_t max_bytes,
                            std::string* bytes) {
  KCRIG_RETURN_IF_ERROR(CheckInputFile(path, max_bytes));
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::Error(path + ": cannot open");
  bytes->assign(std::istreambuf_iterator<char>(in),
                std::istreambuf_iterator<char>());
  if (in.bad()) return Status::Error(path + ": cannot read");
  return Status::Ok();
}

}  // namespace kcrig

#endif  // KCRIG_BASE_INPUT_FILE_H_
