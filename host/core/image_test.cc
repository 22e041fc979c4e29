#include "host/core/image.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

namespace mfns::host {
namespace {

namespace fs = std::filesystem;

// A fresh, empty directory per test.
class PgmTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("mfns_pgm_test_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Path(const std::string& name) const { return (dir_ / name).string(); }

  static std::string ReadBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  static void WriteBytes(const std::string& path, const std::string& bytes) {
    std::ofstream(path, std::ios::binary) << bytes;
  }

  fs::path dir_;
};

cv::Mat RandomImage(int rows, int cols, int type, std::uint64_t seed) {
  cv::Mat image(rows, cols, type);
  std::mt19937_64 rng(seed);
  for (int v = 0; v < rows; ++v) {
    for (int u = 0; u < cols; ++u) {
      if (type == CV_8UC1) {
        image.at<unsigned char>(v, u) = static_cast<unsigned char>(rng());
      } else {
        image.at<std::uint16_t>(v, u) = static_cast<std::uint16_t>(rng());
      }
    }
  }
  // The extremes too.
  if (type == CV_8UC1) {
    image.at<unsigned char>(0, 0) = 0;
    image.at<unsigned char>(0, 1) = 255;
  } else {
    image.at<std::uint16_t>(0, 0) = 0;
    image.at<std::uint16_t>(0, 1) = 65535;
  }
  return image;
}

TEST_F(PgmTest, RoundTripsMono8AndMono16) {
  for (int type : {CV_8UC1, CV_16UC1}) {
    const cv::Mat image = RandomImage(37, 53, type, 4);
    const std::string path = Path(type == CV_8UC1 ? "a.pgm" : "b.pgm");
    WritePgm(path, image);
    const cv::Mat back = ReadPgm(path);
    ASSERT_EQ(back.type(), type);
    ASSERT_EQ(back.size(), image.size());
    EXPECT_EQ(cv::norm(back, image, cv::NORM_INF), 0.0);
  }
  // Only the two files: no temporary left behind.
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 2);
}

TEST_F(PgmTest, WritesTheSpecLayoutBigEndian) {
  cv::Mat wide(1, 2, CV_16UC1);
  wide.at<std::uint16_t>(0, 0) = 0x1234;
  wide.at<std::uint16_t>(0, 1) = 0xABCD;
  WritePgm(Path("w.pgm"), wide);
  EXPECT_EQ(ReadBytes(Path("w.pgm")), std::string("P5\n2 1\n65535\n\x12\x34\xAB\xCD", 17));
  cv::Mat narrow(2, 1, CV_8UC1);
  narrow.at<unsigned char>(0, 0) = 7;
  narrow.at<unsigned char>(1, 0) = 200;
  WritePgm(Path("n.pgm"), narrow);
  EXPECT_EQ(ReadBytes(Path("n.pgm")), std::string("P5\n1 2\n255\n\x07\xC8", 13));
}

TEST_F(PgmTest, WritesARegionOfInterestAndReplacesAnOldFile) {
  const cv::Mat image = RandomImage(20, 30, CV_8UC1, 9);
  const cv::Mat roi = image(cv::Rect(3, 4, 10, 7));  // not continuous
  WritePgm(Path("r.pgm"), image);
  WritePgm(Path("r.pgm"), roi);
  EXPECT_EQ(cv::norm(ReadPgm(Path("r.pgm")), roi, cv::NORM_INF), 0.0);
}

TEST_F(PgmTest, ReadsCommentsAndOtherMaxvals) {
  WriteBytes(Path("c.pgm"), std::string("P5 # a comment\n# another\n3\t2 # w h\n200\n") +
                                std::string("\x01\x02\x03\x04\x05\xC8", 6));
  const cv::Mat a = ReadPgm(Path("c.pgm"));
  ASSERT_EQ(a.type(), CV_8UC1);
  EXPECT_EQ(a.cols, 3);
  EXPECT_EQ(a.rows, 2);
  EXPECT_EQ(a.at<unsigned char>(1, 2), 200);
  WriteBytes(Path("d.pgm"), std::string("P5\n1 1\n1023\n\x03\xFF", 14));
  const cv::Mat b = ReadPgm(Path("d.pgm"));
  ASSERT_EQ(b.type(), CV_16UC1);
  EXPECT_EQ(b.at<std::uint16_t>(0, 0), 1023);
}

TEST_F(PgmTest, RejectsMalformedFiles) {
  const std::string good_raster = std::string("\x01\x02\x03\x04", 4);
  const std::string cases[] = {
      "",                                            // empty
      "P2\n2 2\n255\n1 2 3 4",                       // plain (ASCII) PGM
      "P6\n2 2\n255\n" + good_raster,                // PPM
      "P5\n2 2\n255\n\x01\x02\x03",                  // truncated raster
      "P5\n2 2\n255\n" + good_raster + "x",          // trailing byte
      "P5\n2 2\n0\n" + good_raster,                  // maxval 0
      "P5\n2 2\n70000\n" + good_raster,              // maxval too large
      "P5\n0 2\n255\n",                              // zero width
      "P5\n-2 2\n255\n" + good_raster,               // negative width
      "P5\n2 x\n255\n" + good_raster,                // non-numeric height
      "P5\n2 2\n255",                                // header cut before the raster
      "P5\n2 2\n255x" + good_raster,                 // no whitespace after maxval
      "P5\n2 2\n3\n" + good_raster,                  // sample 4 above maxval 3
      "P5\n99999999999 2\n255\n",                    // absurd width
      "P5\n70000 70000\n255\n",                      // over the pixel limit
      "P5\n2 2\n65535\n" + good_raster,              // 16-bit raster too short
      std::string("P5\n2 1\n1000\n\x03\xE8\x03\xE9", 16), // 16-bit: the last sample 1001 above maxval 1000
  };
  int i = 0;
  for (const std::string& bytes : cases) {
    const std::string path = Path("bad" + std::to_string(i++) + ".pgm");
    WriteBytes(path, bytes);
    EXPECT_THROW(ReadPgm(path), PgmError) << "case " << i - 1;
  }
  EXPECT_THROW(ReadPgm(Path("missing.pgm")), PgmError);
  EXPECT_THROW(ReadPgm(dir_.string()), PgmError);  // a directory: no size to trust
}

TEST_F(PgmTest, RefusesToWriteOtherTypesOrToAMissingDirectory) {
  EXPECT_THROW(WritePgm(Path("f.pgm"), cv::Mat(4, 4, CV_32FC1, cv::Scalar(0))), PgmError);
  EXPECT_THROW(WritePgm(Path("c.pgm"), cv::Mat(4, 4, CV_8UC3, cv::Scalar(0))), PgmError);
  EXPECT_THROW(WritePgm(Path("e.pgm"), cv::Mat()), PgmError);
  EXPECT_THROW(WritePgm(Path("no/such/dir/x.pgm"), cv::Mat(4, 4, CV_8UC1, cv::Scalar(0))), PgmError);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 0);
}

TEST_F(PgmTest, FailedRenameLeavesNoTemporaryAndKeepsTheTarget) {
  // A directory in the way of the rename: the write fails, the directory stays, no temp file.
  fs::create_directories(dir_ / "taken.pgm" / "inside");
  EXPECT_THROW(WritePgm(Path("taken.pgm"), cv::Mat(2, 2, CV_8UC1, cv::Scalar(1))), PgmError);
  EXPECT_TRUE(fs::is_directory(dir_ / "taken.pgm"));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 1);
}

}  // namespace
}  // namespace mfns::host
