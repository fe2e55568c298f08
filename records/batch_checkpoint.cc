#include "records/batch_checkpoint.h"

#include <algorithm>
#include <cerrno>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <system_error>

#include "nlohmann/json.hpp"
#include "records/run_log.h"

namespace kcrig {
namespace {

namespace fs = std::filesystem;

const char kIdentityFile[] = "identity.json";
const std::regex kItemFile(R"(item-(\d{6})\.json)");

std::string ItemPath(const std::string& folder, int item) {
  char name[32];
  std::snprintf(name, sizeof(name), "item-%06d.json", item);
  return (fs::path(folder) / name).string();
}

bool ReadWhole(const std::string& path, std::string* text) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  text->assign(std::istreambuf_iterator<char>(in),
               std::istreambuf_iterator<char>());
  return !in.bad();
}

void Mix(std::uint64_t* hash, const std::string& bytes) {
  for (unsigned char c : bytes) {
    *hash ^= c;
    *hash *= 1099511628211ULL;
  }
}

nlohmann::json IdentityJson(const BatchCheckpoint::Identity& identity) {
  nlohmann::json doc = nlohmann::json::object();
  for (const auto& [key, value] : identity) doc[key] = value;
  return doc;
}

}  // namespace

std::string InputDigest(const std::string& path) {
  std::uint64_t hash = 1469598103934665603ULL;
  std::error_code error;
  if (fs::is_directory(path, error)) {
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(path, error)) {
      if (entry.is_regular_file()) files.push_back(entry.path());
    }
    if (error) return "";
    std::sort(files.begin(), files.end());
    for (const fs::path& file : files) {
      std::string bytes;
      if (!ReadWhole(file.string(), &bytes)) return "";
      Mix(&hash, file.filename().string() + '\0' +
                     std::to_string(bytes.size()) + '\0');
      Mix(&hash, bytes);
    }
  } else {
    std::string bytes;
    if (!ReadWhole(path, &bytes)) return "";
    Mix(&hash, bytes);
  }
  char hex[17];
  std::snprintf(hex, sizeof(hex), "%016" PRIx64, hash);
  return hex;
}

Status BatchCheckpoint::Open(const std::string& folder, Identity identity,
                             int count, bool resume) {
  folder_ = folder;
  identity_ = std::move(identity);
  identity_.emplace_back("kcrig", KCRIG_VERSION);
  count_ = count;
  items_.clear();
  std::error_code error;
  const bool exists =
      fs::symlink_status(folder_, error).type() != fs::file_type::not_found;
  if (!exists) return Create();
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
  return WriteFilesAtomically({{(fs::path(folder_) / kIdentityFile).string(),
                                IdentityJson(identity_).dump(1) + "\n"}});
}

Status BatchCheckpoint::Resume() {
  if (fs::symlink_status(folder_).type() != fs::file_type::directory) {
    return Status::Error(folder_ + ": not a checkpoint folder");
  }
  const std::string identity_path =
      (fs::path(folder_) / kIdentityFile).string();
  std::string text;
  if (!ReadWhole(identity_path, &text)) {
    return Status::Error(identity_path +
                         ": cannot read: " + std::strerror(errno));
  }
  const nlohmann::json kept = nlohmann::json::parse(text, nullptr, false);
  if (!kept.is_object()) {
    return Status::Error(identity_path + ": not a checkpoint's identity");
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
  std::string text;
  if (!ReadWhole(path, &text)) {
    return Status::Error(path + ": cannot read: " + std::strerror(errno));
  }
  const nlohmann::json doc = nlohmann::json::parse(text, nullptr, false);
  const auto bad = [&path](const std::string& why) {
    return Status::Error(path + ": " + why +
                         " (remove the file to run its item again)");
  };
  if (!doc.is_object() || !doc.contains("item") || !doc.contains("result") ||
      !doc.contains("seconds") || !doc["item"].is_number_integer() ||
      !doc["result"].is_string() || !doc["seconds"].is_number()) {
    return bad("not a checkpoint item");
  }
  if (doc["item"] != item) return bad("holds another item");
  if (item >= count_)
    return bad("an item beyond the batch's " + std::to_string(count_));
  items_[item] = {doc["result"].get<std::string>(),
                  doc["seconds"].get<double>()};
  return Status::Ok();
}

Status BatchCheckpoint::Record(int item, const std::string& result,
                               double seconds) {
  const nlohmann::json doc = {
      {"item", item}, {"seconds", seconds}, {"result", result}};
  return WriteFilesAtomically({{ItemPath(folder_, item), doc.dump() + "\n"}});
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
