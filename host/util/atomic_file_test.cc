#include "host/util/atomic_file.h"

#include <gtest/gtest.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>

namespace mfns::host {
namespace {

std::filesystem::path TempDir() {
  std::string tmpl = (std::filesystem::temp_directory_path() / "mfns-atomic-XXXXXX").string();
  EXPECT_NE(::mkdtemp(tmpl.data()), nullptr);
  return tmpl;
}

TEST(AtomicFile, WritesReplacesAndLeavesNoTemp) {
  const auto dir = TempDir();
  const auto file = dir / "out.txt";
  WriteFileAtomic(file, std::string_view("first"));
  EXPECT_EQ(ReadFile(file), "first");
  WriteFileAtomic(file, std::string_view("second, longer"));
  EXPECT_EQ(ReadFile(file), "second, longer");
  int entries = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++entries;
  EXPECT_EQ(entries, 1);
  std::filesystem::remove_all(dir);
}

TEST(AtomicFile, FailureKeepsTheOldFile) {
  const auto dir = TempDir();
  const auto file = dir / "keep.txt";
  WriteFileAtomic(file, std::string_view("good"));
  // A target path whose directory does not exist cannot be written; nothing else changes.
  EXPECT_THROW(WriteFileAtomic(dir / "missing" / "x.txt", std::string_view("bad")), UserError);
  EXPECT_EQ(ReadFile(file), "good");
  std::filesystem::remove_all(dir);
}

// A FIFO (like /dev/null or /dev/stdout, a node that is not a regular file) is written in place:
// renaming a file over it replaced the node itself (as root, `--out /dev/null` turned /dev/null
// into a regular file, and ssh then failed on "/dev/null: bad configuration options").
TEST(AtomicFile, ASpecialFileIsWrittenInPlaceNotReplaced) {
  const auto dir = TempDir();
  const auto fifo = dir / "fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const int reader = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK);  // so that the writer's open returns
  ASSERT_GE(reader, 0);
  WriteFileAtomic(fifo, std::string_view("through the pipe"));
  struct stat st {};
  ASSERT_EQ(::stat(fifo.c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
  char buf[64] = {};
  EXPECT_EQ(::read(reader, buf, sizeof buf), 16);
  EXPECT_EQ(std::string(buf), "through the pipe");
  ::close(reader);
  int entries = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++entries;
  EXPECT_EQ(entries, 1);  // no temp file left beside it
  EXPECT_THROW(WriteFileAtomic(dir, std::string_view("x")), UserError);  // a directory: refused
  std::filesystem::remove_all(dir);
}

TEST(AtomicFile, ReadRefusesMissingAndOversized) {
  const auto dir = TempDir();
  EXPECT_THROW(ReadFile(dir / "nope"), UserError);
  WriteFileAtomic(dir / "big", std::string(100, 'a'));
  EXPECT_THROW(ReadFile(dir / "big", 10), UserError);
  try {
    ReadFile(dir / "big", 10);
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("too large"), std::string::npos);
  }
  std::filesystem::remove_all(dir);
}

// Issue 14, defect 10: a directory or a FIFO given as a file is named as what it is (it read
// "no such file"), a FIFO never blocks, and the size limit quoted is the limit given.
TEST(AtomicFile, ReadSaysWhatIsWrongWithThePath) {
  const auto dir = TempDir();
  const auto what = [](const std::filesystem::path& p, std::size_t max) {
    try {
      ReadFile(p, max);
    } catch (const UserError& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  EXPECT_EQ(what(dir / "nope", 100), (dir / "nope").string() + ": no such file");
  EXPECT_EQ(what(dir, 100), dir.string() + ": is a directory, expected a file");
  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0600), 0);
  EXPECT_EQ(what(dir / "fifo", 100), (dir / "fifo").string() + ": not a regular file (a FIFO, socket or device)");
  WriteFileAtomic(dir / "blob", std::string(16385, 'a'));
  EXPECT_EQ(what(dir / "blob", 16384), (dir / "blob").string() + ": too large (16385 bytes, limit 16384)");
  EXPECT_EQ(ReadFile(dir / "blob", 16385).size(), 16385u);
  // A path holding a newline is named in one line (it was quoted raw: host_cli_fuzz's
  // --scenario, 2026-12-04).
  EXPECT_EQ(what(dir / "no\nfile", 100), (dir / "no").string() + "\\nfile: no such file");
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace mfns::host
