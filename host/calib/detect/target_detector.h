// Calibration-target detection: corner ids (docs/calib-dataset.md) and sub-pixel positions
// in one image, or the reason the image is unusable.
//
// Checkerboard: cv::findChessboardCornersSB (CALIB_CB_ACCURACY by default; optional
//   cv::cornerSubPix after it), then optionally (corner_refine) the model fit of corner_refine.h
//   on the original image. OpenCV's ordering is one of the grid's four symmetries of the target's ids;
//   the printed colours pick it (the target's lower-left square is black, so a flip of an odd
//   number of squares swaps every colour), then the handedness of a view of the printed face
//   (+z_w, host/core/target.h) where colours cannot tell. When cols + rows is even the
//   board looks the same turned by 180 degrees: such views are flagged
//   orientation_ambiguous (ids known up to id -> N - 1 - id) for core/orientation.h to settle
//   from the turntable's kinematics. Square boards (cols == rows) are refused.
// AprilGrid: libapriltag tag36h11; a tag outside the grid's ids is ignored; partial boards
//   are used when at least min_corners corners are seen; a tag touching the image border is
//   dropped (its edge refinement fails there: errors above 1 px). Ids 4 (tag - first_id) + k.
//   libapriltag's pixel centres are at +0.5: corrected to MFNS's integer centres. Optionally
//   (corner_refine) each tag corner is fitted as corner_refine.h's L-corner (X-corner with
//   Kalibr's corner squares) on the original image.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "host/calib/core/calib_types.h"
#include "host/calib/detect/corner_refine.h"
#include "host/core/target.h"

namespace mfns::host {

struct DetectOptions {
  bool sb_accuracy = true;     // CALIB_CB_ACCURACY (upsampled sub-pixel search)
  bool corner_subpix = false;  // cv::cornerSubPix on the SB (or AprilTag) corners
  // Fit the blurred-corner model (corner_refine.h) to each SB corner, or to each AprilGrid tag
  // corner (RefineTagCorner), on the original image; a corner whose fit is refused keeps the
  // detector's position (counted in refine_stats).
  // 5x more exact corners (0.004 px against 0.022 on the paper-calibration dataset) for ~0.07 s
  // of CPU per 1280x1024 image of that dataset (SB + ACCURACY: ~0.5-1 s). mfns-calib turns it on
  // by default (RigCommandOptions::refine_corners; the whole calibration then costs 1.0-1.2x
  // OpenCV's detection alone, docs/benchmarks.md). Off here, for the library's callers: on the
  // dim, blurry images of the rendered-image tests it costs ~0.4 s per image and made them 6.6
  // min slower (host/calib/detect/README.md); those tests choose it where they test it.
  bool corner_refine = false;
  CornerRefineOptions refine;
  int subpix_half_window = 3;  // px
  int min_corners = 8;         // fewer usable corners: the image is skipped
  double border_px = 4.0;      // AprilGrid: a tag with a corner this near the border is dropped
};

struct DetectResult {
  bool ok = false;
  std::string reason;  // why not, when !ok
  std::vector<CornerObs> corners;
  bool orientation_ambiguous = false;
  CornerRefineStats refine_stats;  // with corner_refine: outcome counts
};

// image: CV_8UC1 or CV_16UC1 (scaled to 8 bits for the detectors). Never throws for image
// content; throws UserError for a square checkerboard.
DetectResult DetectTarget(const cv::Mat& image, const CalibrationTarget& target, const DetectOptions& options = {});

// A CV_8UC1 view of a mono image (mono16 scaled by its maximum).
cv::Mat ToMono8(const cv::Mat& image);

}  // namespace mfns::host
