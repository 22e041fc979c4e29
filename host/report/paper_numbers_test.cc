#include "host/report/paper_numbers.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cstdlib>
#include <filesystem>

#include "host/report/pose_errors.h"

namespace mfns::host {
namespace {

// The constants against the transcription of the paper (reference/paper-tables.yaml).
TEST(PaperNumbers, Table5MatchesPaperTablesYaml) {
  const char* src = std::getenv("MFNS_SOURCE_DIR");
  ASSERT_NE(src, nullptr) << "MFNS_SOURCE_DIR is set by mfns_gtest";
  const std::filesystem::path yaml = std::filesystem::path(src) / "reference" / "paper-tables.yaml";
  const YAML::Node t5 = YAML::LoadFile(yaml.string())["table5_navigation"];
  ASSERT_TRUE(t5);
  for (std::size_t a = 0; a < 6; ++a) {
    const YAML::Node axis = t5[kPoseAxes[a]];
    ASSERT_TRUE(axis) << kPoseAxes[a];
    EXPECT_DOUBLE_EQ(axis["mean"].as<double>(), kPaperTable5[a].mean) << kPoseAxes[a];
    EXPECT_DOUBLE_EQ(axis["std"].as<double>(), kPaperTable5[a].std) << kPoseAxes[a];
  }
}

}  // namespace
}  // namespace mfns::host
