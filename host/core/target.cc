#include "host/core/target.h"

#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cstdint>
#include <cmath>
#include <memory>
#include <sstream>
#include <stdexcept>

namespace mfns::host {
namespace {

constexpr int kTagCells = 8;
constexpr double kMm = 1e-3;  // field names and messages are in mm, as the target files and specs  // tag36h11 in libapriltag: width_at_border

// One axis of an AprilGrid: what each cell between consecutive edges is.
struct AxisCell {
  enum Kind : unsigned char { kBorder, kGap, kTag } kind = kBorder;
  int tag = 0;   // tag column (or row) for kTag
  int cell = 0;  // bit cell 0..7 from the low end of the axis for kTag
};

// Edges and cell kinds along one AprilGrid axis with `tags` tags.
void AprilAxis(int tags, double s, double g, double border, std::vector<double>* edges,
               std::vector<AxisCell>* cells) {
  const double end = tags * s + (tags - 1) * g;
  if (border > 0.0) {
    edges->push_back(-g - border);
    cells->push_back({AxisCell::kBorder, 0, 0});
  }
  edges->push_back(-g);
  cells->push_back({AxisCell::kGap, 0, 0});
  for (int t = 0; t < tags; ++t) {
    const double x0 = t * (s + g);
    for (int k = 0; k < kTagCells; ++k) {
      edges->push_back(x0 + k * s / kTagCells);
      cells->push_back({AxisCell::kTag, t, k});
    }
    edges->push_back(x0 + s);
    cells->push_back({AxisCell::kGap, 0, 0});
  }
  edges->push_back(end + g);
  if (border > 0.0) {
    cells->push_back({AxisCell::kBorder, 0, 0});
    edges->push_back(end + g + border);
  }
}

// The 8x8 bit cells of a tag36h11 tag, black[row][col] with row 0 on top, drawn from
// libapriltag's family exactly as its apriltag_to_image does: everything inside the black
// border's outer edge is black except the data bits set in the code (bit i, most significant
// first, is cell (bit_x[i], bit_y[i]) counted from the outer edge; a set bit is white).
using TagBits = std::array<std::array<bool, kTagCells>, kTagCells>;

std::vector<TagBits> Tag36h11Bits(int first_id, int count) {
  std::unique_ptr<apriltag_family_t, void (*)(apriltag_family_t*)> family(tag36h11_create(),
                                                                         tag36h11_destroy);
  if (first_id < 0 || count < 0 ||
      static_cast<long long>(first_id) + count > static_cast<long long>(family->ncodes))
    throw std::invalid_argument("aprilgrid: tag ids must lie in tag36h11's 0.." +
                                std::to_string(family->ncodes - 1));
  if (family->width_at_border != kTagCells || family->reversed_border)
    throw std::runtime_error("aprilgrid: unexpected tag36h11 layout in libapriltag");
  std::vector<TagBits> tags(static_cast<std::size_t>(count));
  for (int i = 0; i < count; ++i) {
    TagBits& tag = tags[static_cast<std::size_t>(i)];
    for (auto& row : tag) row.fill(true);
    const std::uint64_t code = family->codes[first_id + i];
    for (std::uint32_t b = 0; b < family->nbits; ++b) {
      if ((code >> (family->nbits - b - 1)) & 1u) {
        const std::uint32_t x = family->bit_x[b], y = family->bit_y[b];
        if (x >= kTagCells || y >= kTagCells) throw std::runtime_error("aprilgrid: tag36h11 bit outside the tag");
        tag[y][x] = false;
      }
    }
  }
  return tags;
}

// Shortest decimal text that reads back as the same double.
std::string Shortest(double value) {
  std::array<char, 32> buffer{};
  const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  return std::string(buffer.data(), result.ptr);
}

// Field checks of the specs: std::invalid_argument naming the target type and the field.
void CheckCount(const char* type, const char* field, long long value, long long lo, long long hi) {
  if (value < lo || value > hi)
    throw std::invalid_argument(std::string(type) + ": " + field + ": " + std::to_string(value) + " outside " +
                                std::to_string(lo) + ".." + std::to_string(hi));
}

void CheckRange(const char* type, const char* field, double value, double lo, double hi, bool lo_open) {
  const bool ok = std::isfinite(value) && (lo_open ? value > lo : value >= lo) && value <= hi;
  if (!ok)
    throw std::invalid_argument(std::string(type) + ": " + field + ": " + Shortest(value) + " outside " +
                                (lo_open ? "(" : "[") + Shortest(lo) + ", " + Shortest(hi) + "]");
}

}  // namespace

const char* ToString(TargetType type) {
  switch (type) {
    case TargetType::kCheckerboard: return "checkerboard";
    case TargetType::kAprilGrid: return "aprilgrid";
  }
  return "unknown";
}

CalibrationTarget CalibrationTarget::Checkerboard(const CheckerboardSpec& spec) {
  CheckCount("checkerboard", "cols", spec.cols, 2, kMaxCheckerboardCorners);
  CheckCount("checkerboard", "rows", spec.rows, 2, kMaxCheckerboardCorners);
  CheckRange("checkerboard", "square_mm", spec.square_m / kMm, kMinTargetSquareM / kMm, kMaxTargetSquareM / kMm, false);
  CheckRange("checkerboard", "border_mm", spec.border_m / kMm, 0.0, kMaxTargetBorderM / kMm, false);
  CalibrationTarget t;
  t.type_ = TargetType::kCheckerboard;
  t.checkerboard_ = spec;
  const double q = spec.square_m;
  // Edges: [border], squares -1..cols-1 (x) / -1..rows-1 (y), [border].
  auto axis = [&](int inner, std::vector<double>* edges) {
    if (spec.border_m > 0.0) edges->push_back(-q - spec.border_m);
    for (int a = -1; a <= inner; ++a) edges->push_back(a * q);
    if (spec.border_m > 0.0) edges->push_back(inner * q + spec.border_m);
  };
  axis(spec.cols, &t.x_edges_);
  axis(spec.rows, &t.y_edges_);
  const int first_square = spec.border_m > 0.0 ? 1 : 0;  // cell index of square -1
  const int nx = t.num_cells_x(), ny = t.num_cells_y();
  t.ink_.assign(static_cast<std::size_t>(nx * ny), 0);
  for (int iy = 0; iy < ny; ++iy) {
    for (int ix = 0; ix < nx; ++ix) {
      const int a = ix - first_square, b = iy - first_square;  // square index + 1, >= 0 on squares
      const bool square = a >= 0 && a <= spec.cols && b >= 0 && b <= spec.rows;
      t.ink_[static_cast<std::size_t>(iy * nx + ix)] = square && (a + b) % 2 == 0 ? 1 : 0;
    }
  }
  for (int i = 0; i < spec.rows; ++i)
    for (int j = 0; j < spec.cols; ++j)
      t.corners_.push_back({i * spec.cols + j, -1, 0, Eigen::Vector3d(j * q, i * q, 0.0)});
  return t;
}

CalibrationTarget CalibrationTarget::AprilGrid(const AprilGridSpec& spec) {
  // tag36h11's 587 codes bound every count; the product is taken in 64 bits.
  constexpr int kCodes = 587;
  CheckCount("aprilgrid", "first_id", spec.first_id, 0, kCodes - 1);
  CheckCount("aprilgrid", "tag_cols", spec.tag_cols, 1, kCodes);
  CheckCount("aprilgrid", "tag_rows", spec.tag_rows, 1, kCodes);
  CheckCount("aprilgrid", "tag_cols x tag_rows", static_cast<long long>(spec.tag_cols) * spec.tag_rows, 1,
             kCodes - spec.first_id);
  CheckRange("aprilgrid", "tag_size_mm", spec.tag_size_m / kMm, kMinTargetSquareM / kMm, kMaxTargetSquareM / kMm, false);
  CheckRange("aprilgrid", "tag_spacing", spec.tag_spacing, 0.0, kMaxTagSpacing, true);
  CheckRange("aprilgrid", "border_mm", spec.border_m / kMm, 0.0, kMaxTargetBorderM / kMm, false);
  const std::vector<TagBits> bits = Tag36h11Bits(spec.first_id, spec.tag_cols * spec.tag_rows);
  CalibrationTarget t;
  t.type_ = TargetType::kAprilGrid;
  t.aprilgrid_ = spec;
  const double s = spec.tag_size_m, g = spec.tag_spacing * s;
  std::vector<AxisCell> xc, yc;
  AprilAxis(spec.tag_cols, s, g, spec.border_m, &t.x_edges_, &xc);
  AprilAxis(spec.tag_rows, s, g, spec.border_m, &t.y_edges_, &yc);
  const int nx = t.num_cells_x(), ny = t.num_cells_y();
  t.ink_.assign(static_cast<std::size_t>(nx * ny), 0);
  for (int iy = 0; iy < ny; ++iy) {
    for (int ix = 0; ix < nx; ++ix) {
      const AxisCell& cx = xc[static_cast<std::size_t>(ix)];
      const AxisCell& cy = yc[static_cast<std::size_t>(iy)];
      bool black = false;
      if (cx.kind == AxisCell::kGap && cy.kind == AxisCell::kGap) {
        black = spec.corner_squares;
      } else if (cx.kind == AxisCell::kTag && cy.kind == AxisCell::kTag) {
        // Bit cells count up from the tag's bottom; the picture's rows count down from its top.
        const TagBits& tag = bits[static_cast<std::size_t>(cy.tag * spec.tag_cols + cx.tag)];
        black = tag[static_cast<std::size_t>(kTagCells - 1 - cy.cell)][static_cast<std::size_t>(cx.cell)];
      }
      t.ink_[static_cast<std::size_t>(iy * nx + ix)] = black ? 1 : 0;
    }
  }
  for (int r = 0; r < spec.tag_rows; ++r) {
    for (int c = 0; c < spec.tag_cols; ++c) {
      const int index = r * spec.tag_cols + c;
      const double x0 = c * (s + g), y0 = r * (s + g);
      const std::array<Eigen::Vector3d, 4> P = {Eigen::Vector3d(x0, y0, 0.0), Eigen::Vector3d(x0 + s, y0, 0.0),
                                                Eigen::Vector3d(x0 + s, y0 + s, 0.0),
                                                Eigen::Vector3d(x0, y0 + s, 0.0)};
      for (int k = 0; k < 4; ++k)
        t.corners_.push_back({4 * index + k, spec.first_id + index, k, P[static_cast<std::size_t>(k)]});
    }
  }
  return t;
}

Surface CalibrationTarget::SurfaceAt(double x, double y) const {
  if (!(x >= x_edges_.front() && x < x_edges_.back() && y >= y_edges_.front() && y < y_edges_.back()))
    return Surface::kOffTarget;
  const int ix = static_cast<int>(std::upper_bound(x_edges_.begin(), x_edges_.end(), x) - x_edges_.begin()) - 1;
  const int iy = static_cast<int>(std::upper_bound(y_edges_.begin(), y_edges_.end(), y) - y_edges_.begin()) - 1;
  return IsBlack(ix, iy) ? Surface::kBlack : Surface::kWhite;
}

std::string CalibrationTarget::KalibrYaml() const {
  std::ostringstream out;
  if (type_ == TargetType::kCheckerboard) {
    out << "target_type: 'checkerboard'\n"
        << "targetCols: " << checkerboard_.cols << "\n"
        << "targetRows: " << checkerboard_.rows << "\n"
        << "rowSpacingMeters: " << Shortest(checkerboard_.square_m) << "\n"
        << "colSpacingMeters: " << Shortest(checkerboard_.square_m) << "\n";
  } else {
    out << "target_type: 'aprilgrid'\n"
        << "tagCols: " << aprilgrid_.tag_cols << "\n"
        << "tagRows: " << aprilgrid_.tag_rows << "\n"
        << "tagSize: " << Shortest(aprilgrid_.tag_size_m) << "\n"
        << "tagSpacing: " << Shortest(aprilgrid_.tag_spacing) << "\n";
  }
  return out.str();
}

}  // namespace mfns::host
