// A fresh scratch folder per test: ctest runs tests in parallel processes, so no two tests
// (nor two builds running the same test) may share a folder.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>
#include <utility>

namespace ridgeline::testing_support {

/// Removes a test's scratch folder when the test passes; a failed test's folder is kept to
/// be looked at (its path is in the test's output).
class RemoveDirWhenPassed : public ::testing::EmptyTestEventListener {
 public:
  explicit RemoveDirWhenPassed(std::filesystem::path dir) : dir_(std::move(dir)) {}
  void OnTestEnd(const ::testing::TestInfo& info) override {
    if (done_) return;
    done_ = true;
    if (info.result()->Passed()) {
      std::error_code ignored;
      std::filesystem::remove_all(dir_, ignored);
    } else {
      std::printf("test folder kept: %s\n", dir_.string().c_str());
    }
  }

 private:
  std::filesystem::path dir_;
  bool done_ = false;
};

/// temp/ridgeline_<suite>_<test>_<pid>, emptied and created; removed when the test passes.
inline std::filesystem::path fresh_test_dir() {
  const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = std::string("ridgeline_") + info->test_suite_name() + "_" + info->name() +
                     "_" + std::to_string(::getpid());
  for (char& c : name)
    if (c == '/') c = '_';  // parametrized test names contain '/'
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  // gtest owns the listener; it acts once, at the end of the test that made the folder.
  ::testing::UnitTest::GetInstance()->listeners().Append(new RemoveDirWhenPassed(dir));
  return dir;
}

}  // namespace ridgeline::testing_support
