// libFuzzer target for the calibration dataset's files (host/calib/core/dataset): the input is
// cut into a target spec (the command line's --target), target.yaml, images.csv, truth.yaml,
// truth-rig.yaml (fuzz_text.h), written to a scratch directory and read back with
// ReadCalibDataset, and a corners CSV (ParseCornersCsv, as `mfns-calib rig --corners` reads it). Whatever they hold: a dataset or a UserError of one line; a target spec or
// target.yaml that parses gives a target whose corner list is within the detector's limits.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "host/calib/core/dataset.h"
#include "host/util/user_error.h"
#include "tests/fuzz/fuzz_text.h"

namespace {

// Made on the first input, removed at exit (the path outlives every static: never destroyed).
const std::filesystem::path& ScratchDir() {
  static const std::filesystem::path* dir = [] {
    std::string tmpl = (std::filesystem::temp_directory_path() / "calib_dataset_fuzz.XXXXXX").string();
    if (::mkdtemp(tmpl.data()) == nullptr) std::abort();
    auto* path = new std::filesystem::path(tmpl);
    return path;
  }();
  static const bool cleanup = std::atexit([] { std::filesystem::remove_all(ScratchDir()); }) == 0;
  (void)cleanup;
  return *dir;
}

void Put(const std::filesystem::path& path, const std::string& text, bool present) {
  std::filesystem::remove(path);
  if (!present) return;
  std::ofstream(path, std::ios::binary) << text;
}

void CheckTarget(const mfns::host::CalibrationTarget& target) {
  // Bounded (issue 14 defect 5: specs once allocated gigabytes): at most 10^6 corners.
  if (mfns::host::TargetPoints(target).size() > 1'000'000) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::vector<std::string> parts = mfns::fuzz::SplitParts(data, size, 6);
  try {
    CheckTarget(mfns::host::ParseTargetSpec(parts[0]));
  } catch (const mfns::host::UserError& e) {
    mfns::fuzz::CheckMessage(e.what(), "");
  }
  const std::filesystem::path& dir = ScratchDir();
  Put(dir / "target.yaml", parts[1], true);
  Put(dir / "images.csv", parts[2], true);
  Put(dir / "truth.yaml", parts[3], !parts[3].empty());
  Put(dir / "truth-rig.yaml", parts[4], !parts[4].empty());
  try {
    const mfns::host::CalibDataset ds = mfns::host::ReadCalibDataset(dir);
    CheckTarget(ds.target);
  } catch (const mfns::host::UserError& e) {
    mfns::fuzz::CheckMessage(e.what(), "");
  }
  try {
    for (const mfns::host::CornerRow& row : mfns::host::ParseCornersCsv(parts[5], "corners.csv", 88))
      if (row.corner.id < 0 || row.corner.id >= 88 || !row.corner.uv.allFinite()) __builtin_trap();
  } catch (const mfns::host::UserError& e) {
    mfns::fuzz::CheckMessage(e.what(), "corners.csv:");
  }
  return 0;
}
