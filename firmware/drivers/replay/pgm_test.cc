#include "firmware/drivers/replay/pgm.h"

#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <ostream>
#include <set>
#include <string>
#include <vector>

#include "common/limits.h"
#include "firmware/drivers/replay/test_files.h"

namespace mfns::fw {

void PrintTo(PgmStatus s, std::ostream* os) { *os << ToString(s); }

namespace {

using testing::Pgm;
using testing::TestPixel;

PgmStatus Parse(const std::string& s, PgmHeader* h = nullptr) {
  PgmHeader local;
  return ParsePgmHeader(reinterpret_cast<const std::uint8_t*>(s.data()), s.size(),
                        h != nullptr ? h : &local);
}

TEST(PgmStatus, EveryValueHasADistinctName) {
  std::set<std::string> names;
  const int last = static_cast<int>(PgmStatus::kTooLarge);
  for (int i = 0; i <= last; ++i) names.insert(ToString(static_cast<PgmStatus>(i)));
  EXPECT_EQ(names.size(), static_cast<std::size_t>(last + 1));
  EXPECT_EQ(names.count("unknown"), 0U);
}

TEST(ParsePgmHeader, PlainHeader) {
  PgmHeader h;
  ASSERT_EQ(Parse("P5\n640 480\n255\n", &h), PgmStatus::kOk);
  EXPECT_EQ(h.width, 640);
  EXPECT_EQ(h.height, 480);
  EXPECT_EQ(h.maxval, 255);
  EXPECT_EQ(h.format, PixelFormat::kMono8);
  EXPECT_EQ(h.header_bytes, std::strlen("P5\n640 480\n255\n"));
  EXPECT_EQ(h.raster_bytes, 640U * 480U);
}

TEST(ParsePgmHeader, Mono16) {
  PgmHeader h;
  ASSERT_EQ(Parse("P5 3 2 65535 ", &h), PgmStatus::kOk);
  EXPECT_EQ(h.format, PixelFormat::kMono16);
  EXPECT_EQ(h.raster_bytes, 3U * 2U * 2U);
  EXPECT_EQ(h.header_bytes, 13U);
}

TEST(ParsePgmHeader, CommentsAndMixedWhitespace) {
  const std::string text = "P5# right after the magic\n# a line\n\t 4 # width\r\n#\n3\n255\n";
  PgmHeader h;
  ASSERT_EQ(Parse(text, &h), PgmStatus::kOk);
  EXPECT_EQ(h.width, 4);
  EXPECT_EQ(h.height, 3);
  EXPECT_EQ(h.header_bytes, text.size());
}

TEST(ParsePgmHeader, OnlyOneWhitespaceByteEndsTheHeader) {
  // The raster may start with bytes that look like whitespace: they are pixels.
  PgmHeader h;
  ASSERT_EQ(Parse("P5\n2 1\n255\n\n\n", &h), PgmStatus::kOk);
  EXPECT_EQ(h.header_bytes, 11U);
}

TEST(ParsePgmHeader, WrongMagic) {
  EXPECT_EQ(Parse("P2\n4 3\n255\n"), PgmStatus::kBadMagic);  // ASCII PGM
  EXPECT_EQ(Parse("P6\n4 3\n255\n"), PgmStatus::kBadMagic);  // PPM
  EXPECT_EQ(Parse("BM\n4 3\n255\n"), PgmStatus::kBadMagic);
  EXPECT_EQ(Parse("P55 4 3 255\n"), PgmStatus::kBadMagic);
  EXPECT_EQ(Parse("p5\n4 3\n255\n"), PgmStatus::kBadMagic);
}

TEST(ParsePgmHeader, DimensionsOutOfBounds) {
  EXPECT_EQ(Parse("P5\n0 3\n255\n"), PgmStatus::kBadSize);
  EXPECT_EQ(Parse("P5\n4 0\n255\n"), PgmStatus::kBadSize);
  const std::string w = std::to_string(limits::kMaxImageWidth + 1);
  const std::string h = std::to_string(limits::kMaxImageHeight + 1);
  EXPECT_EQ(Parse("P5\n" + w + " 3\n255\n"), PgmStatus::kBadSize);
  EXPECT_EQ(Parse("P5\n4 " + h + "\n255\n"), PgmStatus::kBadSize);
  EXPECT_EQ(Parse("P5\n100000 100000\n255\n"), PgmStatus::kBadSize);
  // Would overflow any integer type: still just "too big".
  EXPECT_EQ(Parse("P5\n99999999999999999999999999 1\n255\n"), PgmStatus::kBadSize);
  const std::string max_w = std::to_string(limits::kMaxImageWidth);
  const std::string max_h = std::to_string(limits::kMaxImageHeight);
  EXPECT_EQ(Parse("P5\n" + max_w + " " + max_h + "\n65535\n"), PgmStatus::kOk);
}

TEST(ParsePgmHeader, BadMaxval) {
  EXPECT_EQ(Parse("P5\n4 3\n0\n"), PgmStatus::kBadMaxval);
  EXPECT_EQ(Parse("P5\n4 3\n65536\n"), PgmStatus::kBadMaxval);
  EXPECT_EQ(Parse("P5\n4 3\n4095\n"), PgmStatus::kBadMaxval);  // valid PGM, not a camera format
  EXPECT_EQ(Parse("P5\n4 3\n254\n"), PgmStatus::kBadMaxval);
  EXPECT_EQ(Parse("P5\n4 3\nabc\n"), PgmStatus::kBadMaxval);
  EXPECT_EQ(Parse("P5\n4 3\n-255\n"), PgmStatus::kBadMaxval);
  EXPECT_EQ(Parse("P5\n4 3\n99999999999999999999\n"), PgmStatus::kBadMaxval);
}

TEST(ParsePgmHeader, MalformedTokens) {
  EXPECT_EQ(Parse("P5\nx 3\n255\n"), PgmStatus::kBadHeader);
  EXPECT_EQ(Parse("P5\n-4 3\n255\n"), PgmStatus::kBadHeader);
  EXPECT_EQ(Parse("P5\n4x3\n255\n"), PgmStatus::kBadHeader);
  EXPECT_EQ(Parse("P5\n4 3\n255#c\n"), PgmStatus::kBadHeader);  // no byte before the raster
}

TEST(ParsePgmHeader, EveryPrefixOfAHeaderIsTruncated) {
  const std::string text = "P5 # c\n12 34\n# x\n65535\n";
  ASSERT_EQ(Parse(text), PgmStatus::kOk);
  for (std::size_t n = 0; n < text.size(); ++n) {
    EXPECT_EQ(Parse(text.substr(0, n)), PgmStatus::kTruncated) << n;
  }
}

TEST(ParsePgmHeader, RandomCorruptionNeverYieldsAnOutOfBoundsHeader) {
  std::mt19937 rng(1234);
  const std::string base = "P5\n# comment\n1280 1024\n65535\n";
  for (int trial = 0; trial < 20000; ++trial) {
    std::string s = base;
    const int edits = 1 + static_cast<int>(rng() % 4);
    for (int e = 0; e < edits; ++e) {
      s[rng() % s.size()] = static_cast<char>(rng() & 0xFF);
    }
    if (rng() % 4 == 0) s.resize(rng() % s.size());
    PgmHeader h;
    if (Parse(s, &h) == PgmStatus::kOk) {
      ASSERT_GE(h.width, 1);
      ASSERT_LE(h.width, limits::kMaxImageWidth);
      ASSERT_GE(h.height, 1);
      ASSERT_LE(h.height, limits::kMaxImageHeight);
      ASSERT_TRUE(h.maxval == 255 || h.maxval == 65535);
      ASSERT_LE(h.header_bytes, s.size());
      ASSERT_LE(h.raster_bytes, limits::kMaxImageBytes);
    }
  }
}

class PgmFileTest : public ::testing::Test {
 protected:
  std::string Write(const std::string& name, const std::string& bytes) {
    const std::string path = dir_.path() + "/" + name;
    testing::WriteFile(path, bytes);
    return path;
  }
  testing::TempDir dir_;
  std::vector<std::uint8_t> buf_ = std::vector<std::uint8_t>(4096, 0);
};

TEST_F(PgmFileTest, ReadsMono8Pixels) {
  const std::string path = Write("a.pgm", Pgm(7, 5, 3));
  PgmHeader h;
  ASSERT_EQ(ReadPgm(path.c_str(), buf_.data(), buf_.size(), &h), PgmStatus::kOk);
  FrameView v;
  v.data = buf_.data();
  v.width = h.width;
  v.height = h.height;
  v.stride_bytes = h.width;
  int wrong = 0;
  for (int y = 0; y < 5; ++y) {
    for (int x = 0; x < 7; ++x) wrong += v.At(x, y) != TestPixel(3, x, y, false);
  }
  EXPECT_EQ(wrong, 0);
}

TEST_F(PgmFileTest, ReadsMono16BigEndianAsLittleEndian) {
  // One pixel written by hand: 0x12 0x34 on disk is the value 0x1234.
  std::string one = "P5\n1 1\n65535\n";
  one.push_back('\x12');
  one.push_back('\x34');
  const std::string p1 = Write("one.pgm", one);
  PgmHeader h;
  ASSERT_EQ(ReadPgm(p1.c_str(), buf_.data(), buf_.size(), &h), PgmStatus::kOk);
  EXPECT_EQ(buf_[0], 0x34);
  EXPECT_EQ(buf_[1], 0x12);

  const std::string path = Write("b.pgm", Pgm(6, 4, 9, true));
  ASSERT_EQ(ReadPgm(path.c_str(), buf_.data(), buf_.size(), &h), PgmStatus::kOk);
  FrameView v;
  v.data = buf_.data();
  v.width = 6;
  v.height = 4;
  v.stride_bytes = 12;
  v.format = PixelFormat::kMono16;
  int wrong = 0;
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 6; ++x) wrong += v.At(x, y) != TestPixel(9, x, y, true);
  }
  EXPECT_EQ(wrong, 0);
}

TEST_F(PgmFileTest, HeaderOnlyReadChecksTheRasterIsThere) {
  PgmHeader h;
  const std::string good = Write("g.pgm", Pgm(8, 8, 1));
  EXPECT_EQ(ReadPgmHeader(good.c_str(), &h), PgmStatus::kOk);
  EXPECT_EQ(h.raster_bytes, 64U);
  std::string cut = Pgm(8, 8, 1);
  cut.pop_back();
  const std::string truncated = Write("t.pgm", cut);
  EXPECT_EQ(ReadPgmHeader(truncated.c_str(), &h), PgmStatus::kTruncated);
}

TEST_F(PgmFileTest, TruncatedRasterOrHeader) {
  PgmHeader h;
  std::string s = Pgm(10, 10, 1);
  s.resize(s.size() - 10);
  const std::string p = Write("short.pgm", s);
  EXPECT_EQ(ReadPgm(p.c_str(), buf_.data(), buf_.size(), &h), PgmStatus::kTruncated);
  const std::string q = Write("head.pgm", "P5\n10 10");
  EXPECT_EQ(ReadPgm(q.c_str(), buf_.data(), buf_.size(), &h), PgmStatus::kTruncated);
  const std::string e = Write("empty.pgm", "");
  EXPECT_EQ(ReadPgm(e.c_str(), buf_.data(), buf_.size(), &h), PgmStatus::kTruncated);
}

TEST_F(PgmFileTest, HugeDeclaredImageInASmallFileIsRefused) {
  PgmHeader h;
  // Declares 2048 x 2048 x 2 bytes, holds 100: never trust the header.
  const std::string p = Write("liar.pgm", "P5\n2048 2048\n65535\n" + std::string(100, 'x'));
  EXPECT_EQ(ReadPgm(p.c_str(), buf_.data(), buf_.size(), &h), PgmStatus::kTruncated);
  const std::string q = Write("huge.pgm", "P5\n50000 50000\n255\n" + std::string(100, 'x'));
  EXPECT_EQ(ReadPgm(q.c_str(), buf_.data(), buf_.size(), &h), PgmStatus::kBadSize);
}

TEST_F(PgmFileTest, RasterLargerThanTheBufferIsRefused) {
  PgmHeader h;
  const std::string p = Write("big.pgm", Pgm(100, 100, 0));  // 10000 bytes > 4096
  EXPECT_EQ(ReadPgm(p.c_str(), buf_.data(), buf_.size(), &h), PgmStatus::kTooLarge);
}

TEST_F(PgmFileTest, OverlongHeaderIsRefused) {
  PgmHeader h;
  const std::string comment = "# " + std::string(limits::kMaxPgmHeaderBytes, 'c') + "\n";
  const std::string p = Write("long.pgm", Pgm(2, 2, 0, false, "P5\n" + comment + "2 2\n255\n"));
  EXPECT_EQ(ReadPgm(p.c_str(), buf_.data(), buf_.size(), &h), PgmStatus::kBadHeader);
}

TEST_F(PgmFileTest, TrailingBytesAreIgnored) {
  PgmHeader h;
  const std::string p = Write("tail.pgm", Pgm(3, 3, 4) + "more");
  ASSERT_EQ(ReadPgm(p.c_str(), buf_.data(), buf_.size(), &h), PgmStatus::kOk);
  EXPECT_EQ(buf_[8], TestPixel(4, 2, 2, false));
}

TEST_F(PgmFileTest, MissingFileAndDirectory) {
  PgmHeader h;
  const std::string missing = dir_.path() + "/nope.pgm";
  EXPECT_EQ(ReadPgm(missing.c_str(), buf_.data(), buf_.size(), &h), PgmStatus::kNotFound);
  EXPECT_EQ(ReadPgm(dir_.path().c_str(), buf_.data(), buf_.size(), &h), PgmStatus::kNotRegular);
}

}  // namespace
}  // namespace mfns::fw
