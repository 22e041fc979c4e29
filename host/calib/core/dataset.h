// Reading a calibration dataset (docs/calib-dataset.md) and the target descriptions the
// command line takes. Every malformed input is a UserError naming the file, line and field.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "common/rig/rig.h"
#include "host/calib/core/calib_types.h"
#include "host/calib/core/kinematics.h"
#include "host/core/target.h"

namespace mfns::host {

// One row of images.csv, its file resolved.
struct DatasetImage {
  std::string camera;
  std::string image;
  ImageKind kind = ImageKind::kTurntable;
  double main_cmd = 0.0;  // rad (turntable images)
  double aux_cmd = 0.0;
  std::filesystem::path path;  // images/<camera>/<image>.pgm
};

// Simulation truth (truth.yaml, truth-rig.yaml), when the dataset has it.
struct DatasetTruth {
  bool has_rig = false;
  Rig rig;
  bool has_mount = false;
  TurntableMount mount;
  double angle_sigma_arcsec = -1.0;  // the simulated turntable error, when truth.yaml says (0: none)
  // Per image "camera/image": true angles (rad) of turntable images, C_k_w and r_w_wk of free ones.
  struct Image {
    ImageKind kind = ImageKind::kTurntable;
    double main_true = 0.0, aux_true = 0.0;
    Eigen::Matrix3d C_k_w = Eigen::Matrix3d::Identity();
    Eigen::Vector3d r_w_wk = Eigen::Vector3d::Zero();
  };
  std::map<std::string, Image> images;
};

struct CalibDataset {
  std::filesystem::path dir;
  CalibrationTarget target = CalibrationTarget::Checkerboard(CheckerboardSpec{});
  std::vector<std::string> cameras;  // in order of first appearance in images.csv
  std::vector<DatasetImage> images;
  DatasetTruth truth;
};

// Reads target.yaml, images.csv and, when present, truth-rig.yaml and truth.yaml. Checks that
// every listed image file exists. Throws UserError.
CalibDataset ReadCalibDataset(const std::filesystem::path& dir);

// target.yaml text <-> target (checkerboard: cols, rows, square_mm; aprilgrid: tag_cols,
// tag_rows, tag_size_mm, tag_spacing, first_id).
CalibrationTarget ParseTargetYaml(const std::string& text, const std::string& source);
std::string FormatTargetYaml(const CalibrationTarget& target);

// The command line's target: "checkerboard:COLSxROWS:SQUARE_MM" (inner corners as OpenCV
// counts them) or "aprilgrid:COLSxROWS:TAG_MM:SPACING[:FIRST_ID]". Throws UserError.
CalibrationTarget ParseTargetSpec(const std::string& spec);

// One row of a corners CSV (camera,image,corner,u_px,v_px, as the dataset's corners.csv and
// `mfns-calib rig --corners`), with its line number.
struct CornerRow {
  std::string camera, image;
  CornerObs corner;
  int line = 0;
};

// Parses a corners CSV's text (host/util/csv_table: header line optional, CRLF accepted, cells
// trimmed, blank lines and lines of spaces skipped); `source` names it in errors. Ids must lie
// in 0..num_ids-1 and not repeat within an image; coordinates must be finite numbers (their
// range depends on the image: checked by the caller). Throws UserError (one line:
// source:LINE: field: why).
std::vector<CornerRow> ParseCornersCsv(const std::string& text, const std::string& source, int num_ids);

// Corner positions by id (target_points[id], m, z = 0).
std::vector<Eigen::Vector3d> TargetPoints(const CalibrationTarget& target);

// The turntable images.csv row's angles are degrees; this is the CSV header the reader expects.
inline constexpr char kImagesCsvHeader[] = "camera,image,kind,main_deg,aux_deg";

}  // namespace mfns::host
