#include "host/util/csv_table.h"

#include <cctype>
#include <sstream>
#include <stdexcept>

#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

std::string Trim(const std::string& s) {
  std::size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}

// Every comma cuts, so "a,b," gives "a", "b" and an empty last cell.
std::vector<std::string> SplitCells(const std::string& line, bool trim) {
  std::vector<std::string> cells;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    const std::string cell = line.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    cells.push_back(trim ? Trim(cell) : cell);
    if (comma == std::string::npos) return cells;
    start = comma + 1;
  }
}

std::string Join(const std::vector<std::string>& cells) {
  std::string joined;
  for (std::size_t i = 0; i < cells.size(); ++i) joined += (i ? "," : "") + cells[i];
  return joined;
}

bool IsBlank(const std::string& line, bool trim) { return trim ? Trim(line).empty() : line.empty(); }

}  // namespace

CsvTable CsvTable::Parse(const std::string& text, const std::string& source, const CsvOptions& options) {
  if (options.header_optional && options.columns.empty())
    throw std::invalid_argument("CsvOptions: header_optional needs the columns");
  CsvTable t;
  t.source_ = source;
  if (options.header_optional) t.header_ = SplitCells(options.columns, false);
  const std::string optional_header_start = t.header_.empty() ? "" : t.header_[0] + ",";
  bool have_header = options.header_optional;
  std::istringstream in(text);
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (n == 1 && options.header_optional && line.rfind(optional_header_start, 0) == 0) {
      t.header_line_ = 1;
      continue;
    }
    if (IsBlank(line, options.trim)) continue;
    std::vector<std::string> cells = SplitCells(line, options.trim);
    if (have_header) {
      t.AddRow(std::move(cells), n);
    } else {
      t.TakeHeader(std::move(cells), n, options);
      have_header = true;
    }
  }
  if (!have_header)
    throw UserError(source + ": empty file (expected " +
                    (options.columns.empty() ? "a header line" : "the header \"" + options.columns + "\"") + ")");
  return t;
}

CsvTable CsvTable::Read(const std::filesystem::path& path, const CsvOptions& options) {
  return Parse(ReadFile(path), path.string(), options);
}

void CsvTable::TakeHeader(std::vector<std::string> cells, int line, const CsvOptions& options) {
  if (!options.columns.empty() && Join(cells) != options.columns)
    throw UserError(source_ + ":" + std::to_string(line) + ": expected the header \"" + options.columns + "\"");
  header_ = std::move(cells);
  header_line_ = line;
}

void CsvTable::AddRow(std::vector<std::string> cells, int line) {
  if (cells.size() != header_.size())
    throw UserError(source_ + ":" + std::to_string(line) + ": expected " + std::to_string(header_.size()) + " cells (" +
                    Join(header_) + "), got " + std::to_string(cells.size()));
  rows_.push_back(std::move(cells));
  lines_.push_back(line);
}

bool CsvTable::HasColumn(const std::string& name) const {
  for (const std::string& h : header_)
    if (h == name) return true;
  return false;
}

int CsvTable::Column(const std::string& name) const {
  for (std::size_t i = 0; i < header_.size(); ++i)
    if (header_[i] == name) return static_cast<int>(i);
  const std::string where = header_line_ > 0 ? source_ + ":" + std::to_string(header_line_) : source_;
  throw UserError(where + ": no column '" + name + "'");
}

const std::string& CsvTable::Cell(std::size_t row, int col) const { return rows_.at(row).at(static_cast<std::size_t>(col)); }

double CsvTable::Number(std::size_t row, int col) const {
  const std::string& cell = Cell(row, col);
  try {
    std::size_t used = 0;
    const double v = std::stod(cell, &used);
    if (used == cell.size()) return v;
  } catch (const std::exception&) {
  }
  throw UserError(source_ + ":" + std::to_string(lines_[row]) + ": column '" + header_[static_cast<std::size_t>(col)] +
                  "': expected a number, got '" + cell + "'");
}

}  // namespace mfns::host
