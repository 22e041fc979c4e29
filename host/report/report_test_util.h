// Test helpers for host/report: a fresh temporary directory and file writing.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

namespace mfns::host {

inline std::filesystem::path FreshTestDir(const std::string& name) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::filesystem::path d =
      std::filesystem::temp_directory_path() / ("mfns_report_" + name + "_" + info->name() + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

inline void WriteText(const std::filesystem::path& p, const std::string& text) {
  std::ofstream(p) << text;
}

}  // namespace mfns::host
