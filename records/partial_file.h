// A log that grows while a run goes on (run.csv, can.log) is written as
// PATH.partial and renamed to PATH only once it is whole: a crash of the
// process keeps every byte written up to it, and never leaves a file under
// the final name that looks complete. A write lands whole or not at all:
// after a failed one (a full disk, a file-size limit) the file is cut back
// to where it was, so it always ends where a whole write ended (a whole
// row); failures are remembered and reported when the file is closed.
#ifndef KCRIG_RECORDS_PARTIAL_FILE_H_
#define KCRIG_RECORDS_PARTIAL_FILE_H_

#include <cstdint>
#include <string>
#include <string_view>

#include "base/atomic_files.h"
#include "base/status.h"

namespace kcrig {

class PartialFile {
 public:
  PartialFile() = default;
  ~PartialFile();  // closes; PATH.partial stays, as after a crash
  PartialFile(const PartialFile&) = delete;
  PartialFile& operator=(const PartialFile&) = delete;

  // Creates the parent directory of `path` and opens `path`.partial; both
  // must be replaceable (CheckReplaceable).
  Status Open(const std::string& path);
  bool is_open() const { return fd_ >= 0; }

  // Appends `bytes` to the kernel's copy of the file (they survive the
  // process), whole or not at all; false when it failed (the file is as
  // before; `error` says why).
  bool Write(std::string_view bytes);

  // Closes: an error naming PATH.partial when any write failed (what was
  // written is kept there).
  Status Close();
  // Close, then rename PATH.partial to PATH.
  Status Commit();
  // Closes and removes PATH.partial (nothing worth keeping).
  void Discard();

  const std::string& path() const { return path_; }
  const std::string& partial_path() const { return partial_path_; }
  // The first failed write's errno text ("No space left on device"), or "".
  const std::string& error() const { return error_; }

 private:
  std::string path_, partial_path_;
  int fd_ = -1;
  std::uint64_t size_ = 0;  // bytes of whole writes
  bool failed_ = false;
  std::string error_;
};

}  // namespace kcrig

#endif  // KCRIG_RECORDS_PARTIAL_FILE_H_
