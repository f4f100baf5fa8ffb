// A fresh scratch folder per test: ctest runs tests in parallel processes, so no two tests
// (nor two builds running the same test) may share a folder.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

namespace ridgeline::testing_support {

/// temp/ridgeline_<suite>_<test>_<pid>, emptied and created.
inline std::filesystem::path fresh_test_dir() {
  const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = std::string("ridgeline_") + info->test_suite_name() + "_" + info->name() +
                     "_" + std::to_string(::getpid());
  for (char& c : name)
    if (c == '/') c = '_';  // parametrized test names contain '/'
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace ridgeline::testing_support
