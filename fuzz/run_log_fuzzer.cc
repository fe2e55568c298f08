// The run-log reader on any pair of files: the first two bytes give the
// length of the sidecar (run.json), the rest is run.csv. An error, or a log
// of at least two finite samples whose time increases strictly.
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "records/run_log.h"

namespace {

namespace fs = std::filesystem;

const fs::path& Directory() {
  static const fs::path directory = [] {
    const fs::path d = fs::temp_directory_path() /
                       ("kcrig_run_log_fuzz_" + std::to_string(getpid()));
    fs::create_directories(d);
    return d;
  }();
  return directory;
}

void Write(const fs::path& path, const std::uint8_t* data, std::size_t size) {
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data),
             static_cast<std::streamsize>(size));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  if (size < 2) return 0;
  const std::size_t sidecar =
      std::min<std::size_t>(size - 2, data[0] | (data[1] << 8));
  Write(Directory() / "run.json", data + 2, sidecar);
  Write(Directory() / "run.csv", data + 2 + sidecar, size - 2 - sidecar);
  kcrig::RunLog log;
  if (!kcrig::ReadRunLog((Directory() / "run.csv").string(), &log).ok()) {
    return 0;
  }
  if (log.samples.size() < 2 || !(log.metadata.rate > 0)) abort();
  for (std::size_t j = 0; j < log.samples.size(); ++j) {
    const kcrig::LogSample& s = log.samples[j];
    if (!std::isfinite(s.t) || !s.y.allFinite() || !s.force.allFinite()) {
      abort();
    }
    if (j > 0 && !(s.t > log.samples[j - 1].t)) abort();
  }
  return 0;
}
