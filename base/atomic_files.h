// Files replaced whole or not at all, and never through a link or over a
// device: every result file, checkpoint and shared input is written
// through WriteFilesAtomically (a growing log through
// records/partial_file.h, which checks its paths the same way).
#ifndef KCRIG_BASE_ATOMIC_FILES_H_
#define KCRIG_BASE_ATOMIC_FILES_H_

#include <string>
#include <utility>
#include <vector>

#include "base/status.h"

namespace kcrig {

// Whether kcrig may put a file at `path`: nothing there, or a regular file
// (replaced). A device, FIFO, directory or symbolic link is never replaced:
// writing "est.json" over /dev/full or a link would destroy what is there.
Status CheckReplaceable(const std::string& path);

// Writes each (path, content) through a temporary in the same directory and
// renames them all only when every temporary was written; on failure no
// target is left half-written or newly created. Only nothing or a regular
// file is replaced (CheckReplaceable); a path given twice is an error.
Status WriteFilesAtomically(
    const std::vector<std::pair<std::string, std::string>>& files);

}  // namespace kcrig

#endif  // KCRIG_BASE_ATOMIC_FILES_H_
