// A CSV file with a header line, read whole, cells addressed by column name (the CSVs of
// DESIGN.md: truth.csv, poses.csv, crb.csv, blobs.csv). Comma-separated, no quoting (none of
// those files quote). Host only; allocates.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace mfns::host {

class CsvTable {
 public:
  // Parses `text`; `source` names it in errors. Throws UserError (one line naming source and
  // line) on an empty text or a row whose cell count differs from the header's.
  static CsvTable Parse(const std::string& text, const std::string& source);
  static CsvTable Read(const std::filesystem::path& path);

  std::size_t size() const { return rows_.size(); }
  bool HasColumn(const std::string& name) const;
  // Column index; throws UserError naming the file when the column is missing.
  int Column(const std::string& name) const;
  const std::string& Cell(std::size_t row, int col) const;
  // The cell as a number ("nan" allowed); throws UserError naming file, line and column.
  double Number(std::size_t row, int col) const;
  const std::vector<std::string>& header() const { return header_; }
  const std::string& source() const { return source_; }
  int Line(std::size_t row) const { return lines_[row]; }

 private:
  std::string source_;
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
  std::vector<int> lines_;
};

}  // namespace mfns::host
