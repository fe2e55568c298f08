#include "records/batch_checkpoint.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <regex>
#include <system_error>

#include "base/atomic_files.h"
#include "base/fnv1a.h"
#include "base/input_file.h"
#include "nlohmann/json.hpp"
#include "records/run_log.h"

namespace kcrig {
namespace {

namespace fs = std::filesystem;

const char kIdentityFile[] = "identity.json";
const std::regex kItemFile(R"(item-(\d{6,9})\.json)");
// A case's result is a few KB; the identity a few hundred bytes.
constexpr std::uintmax_t kMaxFileBytes = 64 << 20;

std::string ItemName(int item) {
  char name[32];
  std::snprintf(name, sizeof(name), "item-%06d.json", item);
  return name;
}

nlohmann::json IdentityJson(const BatchCheckpoint::Identity& identity) {
  nlohmann::json doc = nlohmann::json::object();
  for (const auto& [key, value] : identity) doc[key] = value;
  return doc;
}

}  // namespace

std::string InputDigest(const std::string& path) {
  Fnv1a hash;
  std::error_code error;
  std::vector<fs::path> files = {path};
  if (fs::is_directory(path, error)) {
    files.clear();
    for (const auto& entry : fs::directory_iterator(path, error)) {
      if (entry.is_regular_file(error)) files.push_back(entry.path());
    }
    std::sort(files.begin(), files.end());
  }
  if (error) return "";
  for (const fs::path& file : files) {
    std::string bytes;
    if (!ReadInputFile(file.string(), kMaxFileBytes, &bytes).ok()) return "";
    hash.Mix(file.filename().string() + '\0' + std::to_string(bytes.size()) +
             '\0');
    hash.Mix(bytes);
  }
  return hash.Hex();
}

BatchCheckpoint::~BatchCheckpoint() {
  if (lock_fd_ >= 0) close(lock_fd_);
}

Status BatchCheckpoint::Open(const std::string& folder, Identity identity,
                             int count, bool resume) {
  if (lock_fd_ >= 0) close(lock_fd_);
  lock_fd_ = -1;
  folder_ = folder;
  identity_ = std::move(identity);
  identity_.emplace_back("kcrig", KCRIG_VERSION);
  count_ = count;
  items_.clear();
  std::error_code error;
  const fs::file_type type = fs::symlink_status(folder_, error).type();
  if (type == fs::file_type::not_found) return Create();
  if (type != fs::file_type::directory) {
    return Status::Error(folder_ +
                         ": exists and is not a checkpoint folder (remove it "
                         "to start the run)");
  }
  if (!resume) {
    return Status::Error(folder_ +
                         ": the checkpoint of an interrupted run is there "
                         "(--resume goes on from it; remove it to start "
                         "over)");
  }
  return Resume();
}

Status BatchCheckpoint::Create() {
  std::error_code error;
  if (!fs::create_directory(folder_, error) || error) {
    return Status::Error(folder_ + ": cannot create the checkpoint folder: " +
                         (error ? error.message() : "it exists"));
  }
  KCRIG_RETURN_IF_ERROR(
      WriteFilesAtomically({{(fs::path(folder_) / kIdentityFile).string(),
                             IdentityJson(identity_).dump(1) + "\n"}}));
  return Lock();
}

// Held while this process runs the batch: a second job resuming the same
// checkpoint at once would write the same items twice. A file system
// without locks (some NFS or Lustre mounts) goes on unlocked.
Status BatchCheckpoint::Lock() {
  const std::string path = (fs::path(folder_) / "lock").string();
  lock_fd_ = open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (lock_fd_ < 0) {
    return Status::Error(path + ": cannot open: " + std::strerror(errno));
  }
  if (flock(lock_fd_, LOCK_EX | LOCK_NB) != 0 && errno == EWOULDBLOCK) {
    return Status::Error(folder_ +
                         ": in use by another run (one job at a time may "
                         "resume a checkpoint)");
  }
  return Status::Ok();
}

Status BatchCheckpoint::Resume() {
  const std::string identity_path =
      (fs::path(folder_) / kIdentityFile).string();
  std::string text;
  const Status read = ReadInputFile(identity_path, kMaxFileBytes, &text);
  const nlohmann::json kept =
      read.ok() ? nlohmann::json::parse(text, nullptr, false) : nullptr;
  if (!kept.is_object()) {
    const std::string why =
        read.ok() ? identity_path + ": not a checkpoint's" : read.message();
    return Status::Error(why + " (remove " + folder_ + " to start over)");
  }
  for (const auto& [key, value] : identity_) {
    const auto found = kept.find(key);
    const std::string was = found != kept.end() && found->is_string()
                                ? found->get<std::string>()
                                : "(none)";
    if (was != value) {
      return Status::Error(folder_ + ": a checkpoint of another run (" + key +
                           " was " + was + ", is " + value +
                           "): remove it to start over");
    }
  }
  KCRIG_RETURN_IF_ERROR(Lock());
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(folder_, error)) {
    const std::string name = entry.path().filename().string();
    std::smatch number;
    if (!std::regex_match(name, number, kItemFile)) continue;
    KCRIG_RETURN_IF_ERROR(
        ReadItem(entry.path().string(), std::stoi(number[1].str())));
  }
  if (error) return Status::Error(folder_ + ": " + error.message());
  return Status::Ok();
}

Status BatchCheckpoint::ReadItem(const std::string& path, int item) {
  const auto bad = [&path](const std::string& why) {
    return Status::Error(path + ": " + why +
                         " (remove the file to run its item again)");
  };
  std::string text;
  const Status read = ReadInputFile(path, kMaxFileBytes, &text);
  if (!read.ok()) {
    return Status::Error(read.message() +
                         " (remove the file to run its item again)");
  }
  const nlohmann::json doc = nlohmann::json::parse(text, nullptr, false);
  if (!doc.is_object() || !doc.contains("item") || !doc.contains("result") ||
      !doc.contains("seconds") || !doc["item"].is_number_integer() ||
      !doc["result"].is_string() || !doc["seconds"].is_number()) {
    return bad("not a checkpoint item");
  }
  if (doc["item"] != item || fs::path(path).filename() != ItemName(item)) {
    return bad("holds another item");
  }
  if (item >= count_) {
    return bad("an item beyond the batch's " + std::to_string(count_));
  }
  items_[item] = {doc["result"].get<std::string>(),
                  doc["seconds"].get<double>()};
  return Status::Ok();
}

Status BatchCheckpoint::Record(int item, const std::string& result,
                               double seconds) {
  const nlohmann::json doc = {
      {"item", item}, {"seconds", seconds}, {"result", result}};
  return WriteFilesAtomically(
      {{(fs::path(folder_) / ItemName(item)).string(), doc.dump() + "\n"}});
}

Status BatchCheckpoint::Remove() {
  if (folder_.empty()) return Status::Ok();  // never opened
  std::error_code error;
  fs::remove_all(folder_, error);
  if (error) {
    return Status::Error(folder_ +
                         ": cannot remove the checkpoint: " + error.message());
  }
  return Status::Ok();
}

}  // namespace kcrig
