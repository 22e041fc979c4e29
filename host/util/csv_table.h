// The host tools' one CSV reader: a table read whole, cells addressed by column name. It reads
// the CSVs of DESIGN.md (truth.csv, poses.csv, crb.csv, blobs.csv) and the calibration
// dataset's images.csv and corners CSVs. Comma-separated, no quoting (none of them quote).
// Host only; allocates.
//
// What a text may hold, with the defaults: lines end in LF or CRLF; blank lines are skipped
// anywhere (they still count for line numbers); the first non-blank line is the header; every
// other non-blank line is a row with as many cells as the header. "a,b," has three cells, the
// last one empty. CsvOptions adds trimming, an expected header, and an optional one.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "host/util/user_error.h"  // the UserError CsvTable throws

namespace mfns::host {

// Callers name all three fields ({.trim = .., .columns = .., .header_optional = ..}): GCC 12's
// -Wmissing-field-initializers warns (an error under -Werror) when a designated initializer
// leaves one out.
struct CsvOptions {
  // Cells lose leading and trailing whitespace (std::isspace), and a line of only whitespace
  // is blank: for files people edit (images.csv, corners CSVs). Off, cells are kept as written.
  bool trim = false;
  // The columns, comma-separated ("camera,image,kind"). Empty: the header names them, whatever
  // it holds. Given: the header must hold exactly these cells (after trimming), unless
  // header_optional.
  std::string columns;
  // Requires columns. Line 1 is a header when it begins with the first column's name and a
  // comma (as written, before trimming); it is then skipped, its other cells unchecked (corners
  // CSVs have always been read so). Any other non-blank line 1 is a row. The table's header is `columns`.
  bool header_optional = false;
};

class CsvTable {
 public:
  // Parses `text`; `source` names it in errors. Throws UserError, one line:
  //   "<source>: empty file (expected a header line)", or "(expected the header \"<columns>\")":
  //       no non-blank line and the header is not optional;
  //   "<source>:<line>: expected the header \"<columns>\"": the header differs from columns;
  //   "<source>:<line>: expected <n> cells (<header>), got <m>": a row of another length.
  // Throws std::invalid_argument when header_optional is set without columns (a caller's bug).
  static CsvTable Parse(const std::string& text, const std::string& source, const CsvOptions& options = {});
  // Parse of the file's text, with the path as the source; ReadFile's UserErrors (no such
  // file, too large, ...) pass through.
  static CsvTable Read(const std::filesystem::path& path, const CsvOptions& options = {});

  // Rows, the header not counted.
  std::size_t size() const { return rows_.size(); }
  bool HasColumn(const std::string& name) const;
  // Column index; throws UserError "<source>:<header line>: no column '<name>'" when missing.
  int Column(const std::string& name) const;
  // Requires row < size() and 0 <= col < header().size() (else std::out_of_range).
  const std::string& Cell(std::size_t row, int col) const;
  // The whole cell as a number (std::stod: "nan" and "inf" allowed); throws UserError
  // "<source>:<line>: column '<name>': expected a number, got '<cell>'".
  double Number(std::size_t row, int col) const;
  const std::vector<std::string>& header() const { return header_; }
  const std::string& source() const { return source_; }
  // The row's line number in the text, from 1.
  int Line(std::size_t row) const { return lines_.at(row); }

 private:
  void TakeHeader(std::vector<std::string> cells, int line, const CsvOptions& options);
  void AddRow(std::vector<std::string> cells, int line);

  std::string source_;
  std::vector<std::string> header_;
  int header_line_ = 0;  // 0: no header line in the text (header_optional)
  std::vector<std::vector<std::string>> rows_;
  std::vector<int> lines_;
};

}  // namespace mfns::host
