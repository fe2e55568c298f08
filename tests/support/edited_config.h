// A copy of the source config/ in a test's directory with one text edit in
// one file, for tests of settings and of bad input.
#ifndef KCRIG_TESTS_SUPPORT_EDITED_CONFIG_H_
#define KCRIG_TESTS_SUPPORT_EDITED_CONFIG_H_

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "gtest/gtest.h"

namespace kcrig {

// Copies KCRIG_TEST_CONFIG_DIR to `dir` unless it is there already, then
// replaces the first `from` in `dir`/`file` by `to`. Returns `dir`.
inline std::string EditConfig(const std::string& dir, const std::string& file,
                              const std::string& from, const std::string& to) {
  if (!std::filesystem::exists(dir + "/" + file)) {
    std::filesystem::create_directories(dir);
    std::filesystem::copy(
        KCRIG_TEST_CONFIG_DIR, dir,
        std::filesystem::copy_options::recursive |
            std::filesystem::copy_options::overwrite_existing);
  }
  std::ifstream in(dir + "/" + file);
  std::stringstream text;
  text << in.rdbuf();
  std::string content = text.str();
  const size_t at = content.find(from);
  EXPECT_NE(at, std::string::npos) << file << ": " << from;
  if (at != std::string::npos) content.replace(at, from.size(), to);
  std::ofstream(dir + "/" + file) << content;
  return dir;
}

}  // namespace kcrig

#endif  // KCRIG_TESTS_SUPPORT_EDITED_CONFIG_H_
