// The calibration subcommands of mfns-calib (DESIGN.md, "User-facing interfaces"):
//   mfns-calib rig DATASET_DIR --out DIR [--method ml|paper|opencv-handeye] [options]
//     detection, Zhang per camera, the chosen method; writes rig.yaml, calibration.bin,
//     camchain.yaml, camera-<name>.yaml and report.html (report/outputs.h). Progress on stderr.
//   mfns-calib intrinsics --target checkerboard:COLSxROWS:SQUARE_MM IMAGE... --out DIR
//     Zhang's method on plain images of one camera; writes camera-<name>.yaml (OpenCV
//     FileStorage) and report.txt.
// Errors propagate out of app.parse() as UserError (one line; the tool prints it, exits 1).
#pragma once

#include <CLI/CLI.hpp>

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "host/calib/app/calibrate.h"

namespace mfns::host {

struct RigCommandOptions {
  std::string dataset;
  std::string out_dir;
  std::string method = "ml";
  bool free_k3 = false;
  double huber_px = 1.0;
  std::vector<double> mount_mm;  // r_p_pb (3 numbers); default: truth.yaml's, else 0
  double angle_sigma_arcsec = 8.0;  // default: truth.yaml's turntable_angle_sigma_arcsec when > 0
  bool angle_sigma_set = false;
  std::string reference_camera = "z";
  bool all_a10_rows = false;
  int jobs = 2;
  bool fast_detect = false;
  bool refine_corners = false;  // corner_refine.h model fit after findChessboardCornersSB (--refine-corners)
  std::string rig_id;  // default: truth-rig.yaml's rig id, else "mfns-calibrated"
  std::uint64_t generation = 0;  // the command line's --generation through ParseGenerationOption
  bool generation_set = false;
  bool no_covariance = false;
  bool compare = false;  // also run the other methods on the same corners; compare.csv against the truth
  // Corners from a CSV (camera,image,corner,u_px,v_px: the dataset's corners.csv format, e.g.
  // from another detector) instead of detecting them; and the corners used, written out.
  std::string corners_csv;
  std::string write_corners_csv;
};

// The corners of a CSV in the corners.csv format (docs/calib-dataset.md) as the input of a
// calibration: images of the dataset without rows are skipped. Throws UserError naming the line
// and the field for anything malformed: a corner id the target does not have or one repeated
// in an image, a coordinate that is not a number or lies farther than kCornerMarginPx outside
// its image (pixel centres at integers: the image spans [-0.5, width - 0.5]).
inline constexpr double kCornerMarginPx = 10.0;
CalibInput CornersFromCsv(const CalibDataset& ds, const std::string& path);

// A --generation value: a whole number 0..2^64-1 in decimal digits; anything else ("-1", "1e3",
// "x", 2^64) is a UserError naming the option (CLI11 wrapped "-1" to 2^64-1, refusing every
// later flash as "not newer").
std::uint64_t ParseGenerationOption(const std::string& text);
std::string FormatCornersCsv(const CalibInput& in);

// Runs the rig calibration and writes the outputs; summary and progress go to `log`.
RigCalibration RunRigCommand(const RigCommandOptions& o, std::ostream& log);

struct IntrinsicsCommandOptions {
  std::string target;
  std::vector<std::string> images;
  std::string out_dir;
  std::string camera = "camera";
  bool free_k3 = false;
  bool fast_detect = false;
  bool refine_corners = false;
};

// Zhang's method on the images; writes camera-<camera>.yaml and report.txt into out_dir.
ZhangResult RunIntrinsicsCommand(const IntrinsicsCommandOptions& o, std::ostream& log);

void AddRigCommand(CLI::App& app);
void AddIntrinsicsCommand(CLI::App& app);

}  // namespace mfns::host
