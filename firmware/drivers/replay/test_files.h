// Test support for replay tests: a temporary directory (mkdtemp, removed with its contents at
// the end) and a PGM writer independent of the reader under test.
#pragma once

#include <gtest/gtest.h>
#include <stdlib.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace mfns::fw::testing {

class TempDir {
 public:
  TempDir() {
    const char* base = std::getenv("TMPDIR");
    std::string templ = std::string(base != nullptr && base[0] != '\0' ? base : "/tmp") +
                        "/mfns-replay-XXXXXX";
    std::vector<char> buf(templ.begin(), templ.end());
    buf.push_back('\0');
    if (::mkdtemp(buf.data()) != nullptr) path_ = buf.data();
    EXPECT_FALSE(path_.empty()) << "mkdtemp failed";
  }
  ~TempDir() {
    std::error_code ec;
    if (!path_.empty()) std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

inline void WriteFile(const std::string& path, const std::string& bytes) {
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  ASSERT_TRUE(f.good()) << path;
}

// Pixel value of the synthetic test image number `seed` at (x, y).
inline std::uint16_t TestPixel(int seed, int x, int y, bool mono16) {
  const unsigned v = static_cast<unsigned>(x * 5 + y * 11 + seed * 13);
  return mono16 ? static_cast<std::uint16_t>((v * 263U + 0x0102U) & 0xFFFFU)
                : static_cast<std::uint16_t>(v & 0xFFU);
}

// A binary PGM: header text as given, then the raster of TestPixel(seed) (mono16 big-endian).
inline std::string Pgm(int w, int h, int seed, bool mono16, const std::string& header) {
  std::string s = header;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const std::uint16_t v = TestPixel(seed, x, y, mono16);
      if (mono16) {
        s.push_back(static_cast<char>(v >> 8));
        s.push_back(static_cast<char>(v & 0xFF));
      } else {
        s.push_back(static_cast<char>(v));
      }
    }
  }
  return s;
}

inline std::string Pgm(int w, int h, int seed, bool mono16 = false) {
  return Pgm(w, h, seed, mono16,
             "P5\n" + std::to_string(w) + " " + std::to_string(h) + "\n" +
                 (mono16 ? "65535" : "255") + "\n");
}

inline std::string FramePath(const std::string& dir, const std::string& camera, int frame) {
  char name[16];
  std::snprintf(name, sizeof(name), "%06d.pgm", frame);
  return dir + "/frames/" + camera + "/" + name;
}

}  // namespace mfns::fw::testing
