#include "host/report/csv_table.h"

#include <sstream>

#include "host/util/atomic_file.h"

namespace mfns::host {

CsvTable CsvTable::Parse(const std::string& text, const std::string& source) {
  CsvTable t;
  t.source_ = source;
  std::istringstream in(text);
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    std::vector<std::string> cells;
    std::size_t start = 0;
    while (true) {
      const std::size_t comma = line.find(',', start);
      cells.push_back(line.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
    if (t.header_.empty()) {
      t.header_ = std::move(cells);
      continue;
    }
    if (cells.size() != t.header_.size())
      throw UserError(source + ":" + std::to_string(n) + ": " + std::to_string(cells.size()) + " cells, the header has " +
                      std::to_string(t.header_.size()));
    t.rows_.push_back(std::move(cells));
    t.lines_.push_back(n);
  }
  if (t.header_.empty()) throw UserError(source + ": empty file (expected a header line)");
  return t;
}

CsvTable CsvTable::Read(const std::filesystem::path& path) { return Parse(ReadFile(path), path.string()); }

bool CsvTable::HasColumn(const std::string& name) const {
  for (const std::string& h : header_)
    if (h == name) return true;
  return false;
}

int CsvTable::Column(const std::string& name) const {
  for (std::size_t i = 0; i < header_.size(); ++i)
    if (header_[i] == name) return static_cast<int>(i);
  throw UserError(source_ + ":1: no column '" + name + "'");
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
