// Planar calibration targets: geometry, printed pattern and corner truth in the target frame.
//
// Target frame (the world frame w of a calibration scene, DESIGN.md): the printed sheet lies
// in the plane z = 0; its printed face looks towards +z, so a camera sees the pattern only from
// z > 0 (from behind it sees the plain back of the board). Seen from the front, x points right
// and y up (Kalibr's convention). Units: metres.
//
// Checkerboard: cols x rows inner corners as OpenCV counts them (patternSize = (cols, rows)),
//   square size q. Inner corner (row i, col j) is at (j q, i q, 0), id = i * cols + j. The
//   (cols + 1) x (rows + 1) squares span [-q, cols q] x [-q, rows q]; the square touching the
//   sheet's lower-left corner is black; a white border of border_m surrounds the squares.
//
// AprilGrid (Kalibr's layout): tag_cols x tag_rows tags of libapriltag's tag36h11, tag size s
//   = outer edge of the black border (8 bit cells of s / 8: a 1-cell black border around the
//   6x6 data bits, exactly as libapriltag's apriltag_to_image draws the tag and its detector
//   expects), gap g = tag_spacing * s. Tag (row r, col c) has its lower-left outer corner at
//   (c (s + g), r (s + g), 0) and id first_id + r * tag_cols + c (row by row from the origin).
//   Each tag is drawn upright: the first row of apriltag_to_image's picture is at the tag's top
//   (largest y) as seen from the front. Its 4 corners, in libapriltag's detection order
//   (apriltag_detection_t::p[0..3]), are lower-left, lower-right, upper-right, upper-left:
//   (x0, y0), (x0 + s, y0), (x0 + s, y0 + s), (x0, y0 + s); corner id = 4 (tag - first_id) + k.
//   With corner_squares, Kalibr's black squares of side g fill the gaps' crossings around
//   every tag (Kalibr's own detector uses them; libapriltag does not need them). The sheet
//   extends g + border_m beyond the tags.
//   Differences from Kalibr's printed grid: Kalibr draws its tags with a 2-cell black border
//   for its own detector; here the border is libapriltag's 1 cell so libapriltag reads them.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace mfns::host {

struct CheckerboardSpec {
  int cols = 9;           // inner corners per row (OpenCV patternSize.width), >= 2
  int rows = 6;           // inner corners per column (patternSize.height), >= 2
  double square_m = 0.04;
  double border_m = 0.04;  // white margin around the squares, >= 0
};

struct AprilGridSpec {
  int tag_cols = 6;
  int tag_rows = 6;
  double tag_size_m = 0.04;  // outer edge of the black border
  double tag_spacing = 0.3;  // gap / tag size (Kalibr's tagSpacing), > 0
  int first_id = 0;
  bool corner_squares = false;
  double border_m = 0.02;    // white margin beyond the outer gaps, >= 0
};

enum class TargetType : unsigned char { kCheckerboard, kAprilGrid };
const char* ToString(TargetType type);

// A corner whose image is the truth of a detector.
struct TargetCorner {
  int id = 0;       // checkerboard: i * cols + j; AprilGrid: 4 * (tag_id - first_id) + k
  int tag_id = -1;  // AprilGrid tag id (libapriltag's), -1 for a checkerboard
  int k = 0;        // AprilGrid corner 0..3 in libapriltag's p[] order; 0 for a checkerboard
  Eigen::Vector3d P_w = Eigen::Vector3d::Zero();  // target frame, m (z = 0)
};

// What the sheet shows at a point of its plane (seen from the front).
enum class Surface : unsigned char { kOffTarget, kWhite, kBlack };

// A target's printed pattern as a piecewise-constant sheet on a rectilinear grid of cells:
// cell (ix, iy) spans [x_edges[ix], x_edges[ix + 1]] x [y_edges[iy], y_edges[iy + 1]]; the
// sheet is the union of the cells. Immutable after construction; cheap to copy.
class CalibrationTarget {
 public:
  // Throw std::invalid_argument, naming the field as target.yaml does ("aprilgrid: first_id:
  // 2147483647 outside 0..586", lengths in mm: "checkerboard: square_mm: ..."), on anything
  // outside the bounds below (checked before any arithmetic or allocation, so no count can
  // overflow or allocate more than a few MB):
  //   checkerboard cols, rows      2..kMaxCheckerboardCorners (inner corners per side)
  //   aprilgrid tag_cols, tag_rows 1..587 each, tag_cols * tag_rows <= 587 - first_id
  //   aprilgrid first_id           0..586 (tag36h11 has 587 codes)
  //   square_m, tag_size_m         kMinTargetSquareM..kMaxTargetSquareM (0.1 mm .. 1000 mm)
  //   tag_spacing                  (0, kMaxTagSpacing]
  //   border_m                     0..kMaxTargetBorderM (1000 mm)
  // Non-finite values are refused too.
  static constexpr int kMaxCheckerboardCorners = 200;
  static constexpr double kMinTargetSquareM = 1e-4;
  static constexpr double kMaxTargetSquareM = 1.0;
  static constexpr double kMaxTagSpacing = 10.0;
  static constexpr double kMaxTargetBorderM = 1.0;
  static CalibrationTarget Checkerboard(const CheckerboardSpec& spec);
  static CalibrationTarget AprilGrid(const AprilGridSpec& spec);

  TargetType type() const { return type_; }
  const CheckerboardSpec& checkerboard() const { return checkerboard_; }  // valid for its type
  const AprilGridSpec& aprilgrid() const { return aprilgrid_; }           // valid for its type

  const std::vector<TargetCorner>& corners() const { return corners_; }
  const std::vector<double>& x_edges() const { return x_edges_; }  // increasing
  const std::vector<double>& y_edges() const { return y_edges_; }
  int num_cells_x() const { return static_cast<int>(x_edges_.size()) - 1; }
  int num_cells_y() const { return static_cast<int>(y_edges_.size()) - 1; }
  bool IsBlack(int ix, int iy) const {
    return ink_[static_cast<std::size_t>(iy) * static_cast<std::size_t>(num_cells_x()) +
                static_cast<std::size_t>(ix)] != 0;
  }

  // The pattern at (x, y) in the plane z = 0 (a point on a cell edge belongs to the upper cell).
  Surface SurfaceAt(double x, double y) const;

  // The target in Kalibr's target YAML (target_type, tagCols/..., or targetCols/...).
  std::string KalibrYaml() const;

 private:
  CalibrationTarget() = default;

  TargetType type_ = TargetType::kCheckerboard;
  CheckerboardSpec checkerboard_;
  AprilGridSpec aprilgrid_;
  std::vector<TargetCorner> corners_;
  std::vector<double> x_edges_, y_edges_;
  std::vector<unsigned char> ink_;  // 1 = black, row-major over (iy, ix)
};

}  // namespace mfns::host
