// The calibration subcommands of mfns-calib (DESIGN.md, "User-facing interfaces"):
//   mfns-calib rig DATASET_DIR --out DIR [--method ml|paper|opencv-handeye] [options]
//     detection, Zhang per camera, the chosen method; writes rig.yaml, calibration.bin,
//     camchain.yaml, camera-<name>.yaml and report.html (report/outputs.h). Progress on stderr.
//   mfns-calib intrinsics --target checkerboard:COLSxROWS:SQUARE_MM IMAGE... --out DIR
//     Zhang's method on plain images of one camera; writes camera-<name>.yaml (OpenCV
//     FileStorage) and report.txt.
// The command line is parsed by calib_cli.h (nothing runs there); these run the commands and
// throw UserError (one line; the tool prints it, exits 1).
#pragma once

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "host/calib/app/calib_cli.h"  // the options of rig and intrinsics
#include "host/calib/app/calibrate.h"

namespace mfns::host {

// The corners of a CSV in the corners.csv format (docs/calib-dataset.md) as the input of a
// calibration: images of the dataset without rows are skipped. Throws UserError naming the line
// and the field for anything malformed: a corner id the target does not have or one repeated
// in an image, a coordinate that is not a number or lies farther than kCornerMarginPx outside
// its image (pixel centres at integers: the image spans [-0.5, width - 0.5]).
inline constexpr double kCornerMarginPx = 10.0;
CalibInput CornersFromCsv(const CalibDataset& ds, const std::string& path);

std::string FormatCornersCsv(const CalibInput& in);

// Runs the rig calibration and writes the outputs; summary and progress go to `log`.
RigCalibration RunRigCommand(const RigCommandOptions& o, std::ostream& log);

// Zhang's method on the images; writes camera-<camera>.yaml and report.txt into out_dir.
ZhangResult RunIntrinsicsCommand(const IntrinsicsCommandOptions& o, std::ostream& log);

}  // namespace mfns::host
