// libFuzzer target for the host's CSV reader (host/report/csv_table: truth.csv, poses.csv,
// crb.csv, blobs.csv): whatever the text, Parse gives a table or a UserError of one line naming
// the file; every row of a table has the header's cell count, and every cell reads as a number
// or fails with a one-line UserError naming the file, line and column.
#include <cstddef>
#include <cstdint>
#include <string>

#include "host/report/csv_table.h"
#include "host/util/user_error.h"
#include "tests/fuzz/fuzz_text.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const mfns::host::CsvTable t = mfns::host::CsvTable::Parse(text, "poses.csv");
    const int cols = static_cast<int>(t.header().size());
    for (std::size_t r = 0; r < t.size() && r < 64; ++r) {
      if (t.Line(r) < 2) __builtin_trap();
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
  return 0;
}
