// A test fixture with a fresh, empty directory per test, named after the
// suite and the test, removed afterwards.
#ifndef KCRIG_TESTS_SUPPORT_TEMP_DIR_TEST_H_
#define KCRIG_TESTS_SUPPORT_TEMP_DIR_TEST_H_

#include <filesystem>
#include <string>

#include "gtest/gtest.h"

namespace kcrig {

class TempDirTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const ::testing::TestInfo* info =
        ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ =
        std::filesystem::temp_directory_path() /
        (std::string("kcrig_") + info->test_suite_name() + "_" + info->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::string Path(const std::string& name) const {
    return (dir_ / name).string();
  }

  std::filesystem::path dir_;
};

}  // namespace kcrig

#endif  // KCRIG_TESTS_SUPPORT_TEMP_DIR_TEST_H_
