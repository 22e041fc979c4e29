// Test helpers for host/report: a fresh temporary directory and file writing.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>
#include <unistd.h>
#include <vector>

namespace mfns::host {

// The directories FreshTestDir made, removed when the test program exits (each run used to
// leave a dozen behind in /tmp).
struct TestDirs {
  std::vector<std::filesystem::path> dirs;
  TestDirs() = default;
  TestDirs(const TestDirs&) = delete;
  TestDirs& operator=(const TestDirs&) = delete;
  ~TestDirs() {
    std::error_code ec;
    for (const auto& d : dirs) std::filesystem::remove_all(d, ec);
  }
};

inline TestDirs& MadeTestDirs() {
  static TestDirs dirs;
  return dirs;
}

inline std::filesystem::path FreshTestDir(const std::string& name) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::filesystem::path d =
      std::filesystem::temp_directory_path() / ("mfns_report_" + name + "_" + info->name() + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  MadeTestDirs().dirs.push_back(d);
  return d;
}

inline void WriteText(const std::filesystem::path& p, const std::string& text) {
  std::ofstream(p) << text;
}

}  // namespace mfns::host
