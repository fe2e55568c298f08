// A log that grows while a run goes on (run.csv, can.log) is written as
// PATH.partial and renamed to PATH only once it is whole: a crash of the
// process keeps every byte written up to it, and never leaves a file under
// the final name that looks complete. Write failures (a full disk) are
// remembered and reported when the file is closed.
#ifndef KCRIG_RECORDS_PARTIAL_FILE_H_
#define KCRIG_RECORDS_PARTIAL_FILE_H_

#include <cstdio>
#include <string>
#include <string_view>

#include "base/status.h"

namespace kcrig {

// Whether kcrig may put a file at `path`: nothing there, or a regular file
// (replaced). A device, FIFO, directory or symbolic link is never replaced:
// writing "est.json" over /dev/full or a link would destroy what is there.
Status CheckReplaceable(const std::string& path);

class PartialFile {
 public:
  PartialFile() = default;
  ~PartialFile();  // closes; PATH.partial stays, as after a crash
  PartialFile(const PartialFile&) = delete;
  PartialFile& operator=(const PartialFile&) = delete;

  // Creates the parent directory of `path` and opens `path`.partial; both
  // must be replaceable (CheckReplaceable).
  Status Open(const std::string& path);
  bool is_open() const { return file_ != nullptr; }

  // Appends; a short write is remembered. Flush pushes the bytes to the
  // kernel (they survive the process).
  void Write(std::string_view bytes);
  void Flush();

  // Closes: an error naming PATH.partial when any write failed (what was
  // written is kept there).
  Status Close();
  // Close, then rename PATH.partial to PATH.
  Status Commit();
  // Closes and removes PATH.partial (nothing worth keeping).
  void Discard();

  const std::string& path() const { return path_; }
  const std::string& partial_path() const { return partial_path_; }

 private:
  std::string path_, partial_path_;
  std::FILE* file_ = nullptr;
  bool failed_ = false;
};

}  // namespace kcrig

#endif  // KCRIG_RECORDS_PARTIAL_FILE_H_
