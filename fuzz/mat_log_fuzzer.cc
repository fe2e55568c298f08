// The MAT-file run-log reader (libmatio underneath) on any file: an error,
// or a log of at least two finite samples whose time increases strictly.
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "records/mat_run_log.h"

namespace {

namespace fs = std::filesystem;

const fs::path& File() {
  static const fs::path file = [] {
    const fs::path d = fs::temp_directory_path() /
                       ("kcrig_mat_log_fuzz_" + std::to_string(getpid()));
    fs::create_directories(d);
    return d / "run.mat";
  }();
  return file;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  std::ofstream(File(), std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data),
             static_cast<std::streamsize>(size));
  kcrig::RunLog log;
  if (!kcrig::ReadMatRunLog(File().string(), &log).ok()) return 0;
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
