#include "cluster/input_mirror.h"

#include <algorithm>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "base/atomic_files.h"
#include "base/byte_codec.h"
#include "base/input_file.h"

namespace kcrig {
namespace {

namespace fs = std::filesystem;

// Most bytes of one input file, and of all the files of one input: far
// beyond a configuration or a log, below MPI's 2 GiB per message.
constexpr std::uintmax_t kMaxFileBytes = 256u << 20;
constexpr std::uint64_t kMaxInputBytes = 1u << 30;

// The root's files of `path` (name -> bytes), packed: a flag (0: the root
// could not read it, 1: a file, 2: a folder), then the files.
Status Pack(const std::string& path, const std::vector<std::string>& companions,
            std::string* bytes) {
  std::vector<std::string> files;
  std::error_code error;
  const bool folder = fs::is_directory(path, error);
  if (folder) {
    for (const fs::directory_entry& entry :
         fs::directory_iterator(path, error)) {
      if (entry.is_regular_file(error)) files.push_back(entry.path().string());
    }
  } else if (fs::is_regular_file(path, error)) {
    files.push_back(path);
    // Each file once: a companion may name the file itself (the sidecar
    // of a .json log is the log).
    for (const std::string& companion : companions) {
      if (std::find(files.begin(), files.end(), companion) == files.end() &&
          fs::is_regular_file(companion, error)) {
        files.push_back(companion);
      }
    }
  }
  ByteWriter out;
  out.Put<std::uint8_t>(files.empty() ? 0 : (folder ? 2 : 1));
  out.Put<std::uint64_t>(files.size());
  std::uint64_t total = 0;
  for (const std::string& file : files) {
    std::string text;
    KCRIG_RETURN_IF_ERROR(ReadInputFile(file, kMaxFileBytes, &text));
    total += text.size();
    if (total > kMaxInputBytes) {
      return Status::Error(path + ": more than 1 GiB to send to the ranks");
    }
    out.Put(fs::path(file).filename().string());
    out.Put(text);
  }
  *bytes = out.bytes();
  return Status::Ok();
}

// Writes the files of `bytes` into `folder`; `*path` names the copy.
Status Unpack(const std::string& bytes, const std::string& folder,
              std::string* path) {
  ByteReader in(bytes);
  std::uint8_t kind = 0;
  std::uint64_t count = 0;
  in.Get(&kind);
  in.Get(&count);
  if (kind == 0) return Status::Ok();
  std::error_code error;
  fs::create_directories(folder, error);
  if (error) {
    return Status::Error(folder + ": cannot create (" + error.message() + ")");
  }
  std::vector<std::pair<std::string, std::string>> copies;
  for (std::uint64_t i = 0; i < count && i < (1u << 20); ++i) {
    std::string name, text;
    in.Get(&name);
    in.Get(&text);
    // Only a plain name lands in the folder.
    if (name.empty() || name == "." || name == ".." ||
        name.find('/') != std::string::npos) {
      in.Fail();
      break;
    }
    copies.emplace_back((fs::path(folder) / name).string(), std::move(text));
  }
  if (!in.ok()) return Status::Error(*path + ": corrupt when shared");
  KCRIG_RETURN_IF_ERROR(WriteFilesAtomically(copies));
  *path = kind == 2        ? folder
          : copies.empty() ? std::string()
                           : copies.front().first;
  return Status::Ok();
}

}  // namespace

InputMirror::InputMirror(const Ranks& ranks) : ranks_(ranks) {
  if (ranks.size() > 1 && !ranks.is_root()) {
    folder_ = std::make_unique<RankFolder>("inputs", ranks.rank());
  }
}

Status InputMirror::Mirror(std::string* path,
                           const std::vector<std::string>& companions) {
  if (path->empty() || ranks_.size() == 1) return Status::Ok();
  std::string bytes;
  Status status = Status::Ok();
  if (ranks_.is_root()) status = Pack(*path, companions, &bytes);
  status = ranks_.Share(status, &bytes);
  const int index = mirrored_++;
  if (!status.ok() || ranks_.is_root()) return status;
  KCRIG_RETURN_IF_ERROR(folder_->status());
  const std::string folder =
      (fs::path(folder_->path()) / ("input" + std::to_string(index))).string();
  return Unpack(bytes, folder, path);
}

Status ShareFilesInPlace(const Ranks& ranks, Status root_status,
                         const std::vector<std::string>& paths) {
  if (ranks.size() == 1 || paths.empty()) return root_status;
  const fs::path folder = fs::path(paths[0]).parent_path();
  for (const std::string& path : paths) {
    // The same on every rank: no rank goes on to the collective.
    if (fs::path(path).parent_path() != folder) {
      return root_status.ok()
                 ? Status::Error(path + ": not in " + folder.string())
                 : root_status;
    }
  }
  std::string bytes;
  if (ranks.is_root() && root_status.ok()) {
    // Every file is needed (Pack would skip a missing companion).
    for (const std::string& path : paths) {
      std::error_code error;
      if (!fs::is_regular_file(path, error)) {
        root_status = Status::Error(path + ": not written");
        break;
      }
    }
    if (root_status.ok()) {
      root_status = Pack(paths[0], {paths.begin() + 1, paths.end()}, &bytes);
    }
  }
  const Status status = ranks.Share(root_status, &bytes);
  if (!status.ok() || ranks.is_root()) return status;
  std::string first = paths[0];
  return Unpack(bytes, folder.string(), &first);
}

}  // namespace kcrig
