#include "host/util/csv_table.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

const CsvOptions kTrim{.trim = true, .columns = "", .header_optional = false};

// The UserError's message, or "(no error)".
std::string ErrorOf(const std::string& text, const CsvOptions& options = {}) {
  try {
    CsvTable::Parse(text, "t.csv", options);
  } catch (const UserError& e) {
    return e.what();
  }
  return "(no error)";
}

std::string NumberErrorOf(const CsvTable& t, std::size_t row, const std::string& column) {
  try {
    t.Number(row, t.Column(column));
  } catch (const UserError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(CsvTable, HeaderAndCellsByName) {
  const CsvTable t = CsvTable::Parse("frame,status,x_mm\n0,fix,1.5\n1,lost,nan\n", "t.csv");
  EXPECT_EQ(t.header(), (std::vector<std::string>{"frame", "status", "x_mm"}));
  ASSERT_EQ(t.size(), 2u);
  EXPECT_TRUE(t.HasColumn("status"));
  EXPECT_FALSE(t.HasColumn("y_mm"));
  EXPECT_EQ(t.Cell(1, t.Column("status")), "lost");
  EXPECT_DOUBLE_EQ(t.Number(0, t.Column("x_mm")), 1.5);
  EXPECT_TRUE(std::isnan(t.Number(1, t.Column("x_mm"))));
  EXPECT_EQ(t.Line(0), 2);
  EXPECT_EQ(t.source(), "t.csv");
}

TEST(CsvTable, CrlfLineEndings) {
  const CsvTable t = CsvTable::Parse("a,b\r\n1,2\r\n", "t.csv");
  EXPECT_EQ(t.header().back(), "b");
  EXPECT_EQ(t.Cell(0, 1), "2");
  EXPECT_DOUBLE_EQ(t.Number(0, t.Column("b")), 2.0);
}

TEST(CsvTable, BlankLinesAreSkippedButCounted) {
  const CsvTable t = CsvTable::Parse("\na,b\n\r\n1,2\n\n3,4\n", "t.csv");
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t.Line(0), 4);
  EXPECT_EQ(t.Line(1), 6);
  // A line of spaces is blank only when trimming; otherwise it is a row of one cell.
  EXPECT_EQ(CsvTable::Parse("a,b\n  \t\n1,2\n", "t.csv", kTrim).size(), 1u);
  EXPECT_EQ(ErrorOf("a,b\n  \n"), "t.csv:2: expected 2 cells (a,b), got 1");
}

TEST(CsvTable, WrongCellCountNamesFileAndLine) {
  EXPECT_EQ(ErrorOf("a,b,c\n1,2,3\n\n1,2\n"), "t.csv:4: expected 3 cells (a,b,c), got 2");
  EXPECT_EQ(ErrorOf("a,b\n1,2,3\n"), "t.csv:2: expected 2 cells (a,b), got 3");
}

TEST(CsvTable, BadNumberNamesFileLineAndColumn) {
  const CsvTable t = CsvTable::Parse("frame,x_mm\n0,1\n1,1.5mm\n2,\n", "t.csv");
  EXPECT_EQ(NumberErrorOf(t, 1, "x_mm"), "t.csv:3: column 'x_mm': expected a number, got '1.5mm'");
  EXPECT_EQ(NumberErrorOf(t, 2, "x_mm"), "t.csv:4: column 'x_mm': expected a number, got ''");
  EXPECT_EQ(NumberErrorOf(t, 0, "x_mm"), "(no error)");
}

TEST(CsvTable, MissingColumnNamesFileAndColumn) {
  const CsvTable t = CsvTable::Parse("\nframe,x_mm\n0,1\n", "t.csv");
  try {
    t.Column("y_mm");
    FAIL() << "no error";
  } catch (const UserError& e) {
    EXPECT_EQ(std::string(e.what()), "t.csv:2: no column 'y_mm'");
  }
}

TEST(CsvTable, EmptyFile) {
  EXPECT_EQ(ErrorOf(""), "t.csv: empty file (expected a header line)");
  EXPECT_EQ(ErrorOf("\n\r\n"), "t.csv: empty file (expected a header line)");
  const CsvOptions header_ab{.trim = true, .columns = "a,b", .header_optional = false};
  EXPECT_EQ(ErrorOf(" \n", header_ab), "t.csv: empty file (expected the header \"a,b\")");
  // A header and no rows is a table of no rows (the caller decides whether that is an error).
  EXPECT_EQ(CsvTable::Parse("a,b\n", "t.csv").size(), 0u);
  // No header needed: an empty text is an empty table.
  EXPECT_EQ(CsvTable::Parse("", "t.csv", {.trim = false, .columns = "a,b", .header_optional = true}).size(), 0u);
}

TEST(CsvTable, TrailingCommaIsAnEmptyLastCell) {
  const CsvTable t = CsvTable::Parse("a,b,c\n1,2,\n,,\n", "t.csv");
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t.Cell(0, 2), "");
  EXPECT_EQ(t.Cell(1, 0), "");
  EXPECT_EQ(ErrorOf("a,b\n1,2,\n"), "t.csv:2: expected 2 cells (a,b), got 3");
}

TEST(CsvTable, TrimmingKeepsInnerSpaces) {
  const CsvTable t = CsvTable::Parse(" a , b\n x y ,\t2 \n", "t.csv", kTrim);
  EXPECT_EQ(t.header(), (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(t.Cell(0, 0), "x y");
  EXPECT_EQ(t.Cell(0, 1), "2");
  EXPECT_EQ(CsvTable::Parse("a, b\n", "t.csv").header()[1], " b");  // untrimmed by default
}

TEST(CsvTable, ExpectedHeaderMustMatch) {
  const CsvOptions images{.trim = true, .columns = "camera,image,kind", .header_optional = false};
  EXPECT_EQ(CsvTable::Parse("\ncamera, image ,kind\nz,000,free\n", "t.csv", images).size(), 1u);
  EXPECT_EQ(ErrorOf("\ncamera,image\nz,000\n", images), "t.csv:2: expected the header \"camera,image,kind\"");
  EXPECT_EQ(ErrorOf("camera,image,kind,extra\n", images), "t.csv:1: expected the header \"camera,image,kind\"");
}

TEST(CsvTable, OptionalHeaderIsLineOneStartingWithTheFirstColumn) {
  const CsvOptions corners{.trim = true, .columns = "camera,image,corner", .header_optional = true};
  const CsvTable with = CsvTable::Parse("camera,image,corner\r\nx,1,3\n", "t.csv", corners);
  ASSERT_EQ(with.size(), 1u);
  EXPECT_EQ(with.Line(0), 2);
  const CsvTable without = CsvTable::Parse("x,1,3\n\ny,2,4\n", "t.csv", corners);
  ASSERT_EQ(without.size(), 2u);
  EXPECT_EQ(without.header(), (std::vector<std::string>{"camera", "image", "corner"}));
  EXPECT_EQ(without.Cell(1, without.Column("corner")), "4");
  EXPECT_EQ(without.Line(1), 3);
  // Only line 1 can be the header; later, or indented, it is a row like any other.
  EXPECT_EQ(CsvTable::Parse("\ncamera,image,corner\n", "t.csv", corners).Cell(0, 0), "camera");
  EXPECT_EQ(CsvTable::Parse(" camera,a,1\n", "t.csv", corners).size(), 1u);
  EXPECT_EQ(ErrorOf("x,1\n", corners), "t.csv:1: expected 3 cells (camera,image,corner), got 2");
  const CsvOptions no_columns{.trim = false, .columns = "", .header_optional = true};
  EXPECT_THROW(CsvTable::Parse("a\n", "t.csv", no_columns), std::invalid_argument);
}

TEST(CsvTable, ReadNamesThePath) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("csv_table_test." + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  WriteFileAtomic(dir / "r.csv", std::string("a,b\n1\n"));
  try {
    CsvTable::Read(dir / "r.csv");
    FAIL() << "no error";
  } catch (const UserError& e) {
    EXPECT_EQ(std::string(e.what()), (dir / "r.csv").string() + ":2: expected 2 cells (a,b), got 1");
  }
  EXPECT_THROW(CsvTable::Read(dir / "nope.csv"), UserError);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace mfns::host
