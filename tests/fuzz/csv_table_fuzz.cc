// libFuzzer target for the host's CSV reader (host/util/csv_table), read three ways: as the CSVs
// of DESIGN.md (truth.csv, poses.csv, crb.csv, blobs.csv), trimmed with images.csv's expected
// header, and trimmed with the corners CSVs' optional one. Whatever the text, Parse gives a table
// or a UserError of one line naming the file; every row of a table has the header's cell count,
// and every cell reads as a number or fails with a one-line UserError naming the file, line and
// column.
#include <cstddef>
#include <cstdint>
#include <string>

#include "host/util/csv_table.h"
#include "host/util/user_error.h"
#include "tests/fuzz/fuzz_text.h"

namespace {

void Check(const std::string& text, const mfns::host::CsvOptions& options) {
  try {
    const mfns::host::CsvTable t = mfns::host::CsvTable::Parse(text, "poses.csv", options);
    const int cols = static_cast<int>(t.header().size());
    for (std::size_t r = 0; r < t.size() && r < 64; ++r) {
      if (t.Line(r) < 1 || (!options.header_optional && t.Line(r) < 2)) __builtin_trap();
      for (int c = 0; c < cols; ++c) {
        t.Cell(r, c);
        try {
          t.Number(r, c);
        } catch (const mfns::host::UserError& e) {
          mfns::fuzz::CheckMessage(e.what(), "poses.csv:");
        }
      }
    }
    if (cols > 0) t.Column(t.header()[0]);
  } catch (const mfns::host::UserError& e) {
    mfns::fuzz::CheckMessage(e.what(), "poses.csv");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  Check(text, {.trim = false, .columns = "", .header_optional = false});
  Check(text, {.trim = true, .columns = "camera,image,kind", .header_optional = false});    // as images.csv
  Check(text, {.trim = true, .columns = "camera,image,corner", .header_optional = true});  // as corners CSVs
  return 0;
}
