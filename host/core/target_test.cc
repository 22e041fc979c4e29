#include "host/core/target.h"

#include <apriltag/apriltag.h>
#include <apriltag/common/image_u8.h>
#include <apriltag/tag36h11.h>
#include <gtest/gtest.h>

#include <memory>

namespace mfns::host {
namespace {

TEST(Checkerboard, CornersAreOpenCvsGridInOrder) {
  const CalibrationTarget t = CalibrationTarget::Checkerboard({7, 5, 0.03, 0.02});
  EXPECT_EQ(t.type(), TargetType::kCheckerboard);
  ASSERT_EQ(t.corners().size(), 35u);
  for (int i = 0; i < 5; ++i) {
    for (int j = 0; j < 7; ++j) {
      const TargetCorner& c = t.corners()[static_cast<std::size_t>(i * 7 + j)];
      EXPECT_EQ(c.id, i * 7 + j);
      EXPECT_EQ(c.tag_id, -1);
      EXPECT_TRUE(c.P_w.isApprox(Eigen::Vector3d(j * 0.03, i * 0.03, 0.0)));
    }
  }
}

TEST(Checkerboard, EveryInnerCornerIsASaddleOfTheSquares) {
  const CalibrationTarget t = CalibrationTarget::Checkerboard({7, 5, 0.03, 0.02});
  const double e = 0.005;
  for (const TargetCorner& c : t.corners()) {
    const double x = c.P_w.x(), y = c.P_w.y();
    const Surface ll = t.SurfaceAt(x - e, y - e), lr = t.SurfaceAt(x + e, y - e);
    const Surface ul = t.SurfaceAt(x - e, y + e), ur = t.SurfaceAt(x + e, y + e);
    EXPECT_NE(ll, Surface::kOffTarget);
    EXPECT_EQ(ll, ur);
    EXPECT_EQ(lr, ul);
    EXPECT_NE(ll, lr);
  }
  // The square at the sheet's lower-left corner is black; border white; beyond: no target.
  EXPECT_EQ(t.SurfaceAt(-0.015, -0.015), Surface::kBlack);
  EXPECT_EQ(t.SurfaceAt(-0.04, -0.015), Surface::kWhite);
  EXPECT_EQ(t.SurfaceAt(7 * 0.03 + 0.019, 0.0), Surface::kWhite);
  EXPECT_EQ(t.SurfaceAt(7 * 0.03 + 0.021, 0.0), Surface::kOffTarget);
  EXPECT_EQ(t.SurfaceAt(0.0, -0.03 - 0.021), Surface::kOffTarget);
  EXPECT_DOUBLE_EQ(t.x_edges().front(), -0.05);
  EXPECT_DOUBLE_EQ(t.y_edges().back(), 5 * 0.03 + 0.02);
}

TEST(Checkerboard, NoBorderAndBadSpecs) {
  const CalibrationTarget t = CalibrationTarget::Checkerboard({3, 2, 0.05, 0.0});
  EXPECT_EQ(t.num_cells_x(), 4);
  EXPECT_EQ(t.num_cells_y(), 3);
  EXPECT_EQ(t.SurfaceAt(-0.051, 0.0), Surface::kOffTarget);
  EXPECT_THROW(CalibrationTarget::Checkerboard({1, 5, 0.03, 0.0}), std::invalid_argument);
  EXPECT_THROW(CalibrationTarget::Checkerboard({5, 5, 0.0, 0.0}), std::invalid_argument);
  EXPECT_THROW(CalibrationTarget::Checkerboard({5, 5, 0.03, -0.01}), std::invalid_argument);
}

TEST(AprilGrid, CornersFollowLibapriltagOrderAroundEachTag) {
  AprilGridSpec spec;
  spec.tag_cols = 3;
  spec.tag_rows = 2;
  spec.tag_size_m = 0.05;
  spec.tag_spacing = 0.2;
  spec.first_id = 10;
  const CalibrationTarget t = CalibrationTarget::AprilGrid(spec);
  ASSERT_EQ(t.corners().size(), 24u);
  const double s = 0.05, pitch = 0.06;
  for (int r = 0; r < 2; ++r) {
    for (int c = 0; c < 3; ++c) {
      const int index = r * 3 + c;
      const Eigen::Vector3d ll(c * pitch, r * pitch, 0.0);
      const Eigen::Vector3d expected[4] = {ll, ll + Eigen::Vector3d(s, 0, 0), ll + Eigen::Vector3d(s, s, 0),
                                           ll + Eigen::Vector3d(0, s, 0)};
      for (int k = 0; k < 4; ++k) {
        const TargetCorner& corner = t.corners()[static_cast<std::size_t>(4 * index + k)];
        EXPECT_EQ(corner.tag_id, 10 + index);
        EXPECT_EQ(corner.k, k);
        EXPECT_EQ(corner.id, 4 * index + k);
        EXPECT_TRUE(corner.P_w.isApprox(expected[k])) << corner.P_w.transpose();
      }
    }
  }
  EXPECT_NE(t.KalibrYaml().find("tagSpacing: 0.2\n"), std::string::npos);
  EXPECT_NE(t.KalibrYaml().find("target_type: 'aprilgrid'"), std::string::npos);
}

// Each tag's 8x8 cells are libapriltag's own picture of that tag (apriltag_to_image), upright
// when the target is seen from the front (x right, y up).
TEST(AprilGrid, TagCellsAreLibapriltagsPicture) {
  AprilGridSpec spec;
  spec.tag_cols = 4;
  spec.tag_rows = 3;
  spec.first_id = 100;
  const CalibrationTarget t = CalibrationTarget::AprilGrid(spec);
  std::unique_ptr<apriltag_family_t, void (*)(apriltag_family_t*)> family(tag36h11_create(), tag36h11_destroy);
  const double s = spec.tag_size_m, g = spec.tag_spacing * s, cell = s / 8;
  for (int r = 0; r < spec.tag_rows; ++r) {
    for (int c = 0; c < spec.tag_cols; ++c) {
      const int id = spec.first_id + r * spec.tag_cols + c;
      std::unique_ptr<image_u8_t, void (*)(image_u8_t*)> picture(apriltag_to_image(family.get(), id),
                                                                 image_u8_destroy);
      ASSERT_EQ(picture->width, 10);
      const double x0 = c * (s + g), y_top = r * (s + g) + s;
      for (int row = 0; row < 10; ++row) {
        for (int col = 0; col < 10; ++col) {
          // Picture pixel (row, col) is the cell whose centre is (col - 1 + .5, row - 1 + .5)
          // cells from the tag's top-left outer corner; the picture's outer ring is the white gap.
          const Surface surface = t.SurfaceAt(x0 + (col - 0.5) * cell, y_top - (row - 0.5) * cell);
          const bool black = picture->buf[row * picture->stride + col] < 128;
          EXPECT_EQ(surface, black ? Surface::kBlack : Surface::kWhite) << "tag " << id << " " << row << "," << col;
        }
      }
    }
  }
}

TEST(AprilGrid, CornerSquaresFillTheGapCrossings) {
  AprilGridSpec spec;
  spec.tag_cols = 2;
  spec.tag_rows = 2;
  spec.corner_squares = true;
  const CalibrationTarget with = CalibrationTarget::AprilGrid(spec);
  spec.corner_squares = false;
  const CalibrationTarget without = CalibrationTarget::AprilGrid(spec);
  const double s = spec.tag_size_m, g = spec.tag_spacing * s;
  for (double x : {-g / 2, s + g / 2, 2 * s + 1.5 * g}) {
    for (double y : {-g / 2, s + g / 2, 2 * s + 1.5 * g}) {
      EXPECT_EQ(with.SurfaceAt(x, y), Surface::kBlack);
      EXPECT_EQ(without.SurfaceAt(x, y), Surface::kWhite);
    }
  }
  // Gaps between tags stay white away from the crossings.
  EXPECT_EQ(with.SurfaceAt(s / 2, s + g / 2), Surface::kWhite);
  EXPECT_EQ(with.SurfaceAt(-g - spec.border_m / 2, 0.0), Surface::kWhite);
  EXPECT_EQ(with.SurfaceAt(-g - spec.border_m - 1e-6, 0.0), Surface::kOffTarget);
}

TEST(AprilGrid, RejectsBadSpecs) {
  AprilGridSpec spec;
  spec.first_id = 580;  // 36 tags would run past tag36h11's 587 codes
  EXPECT_THROW(CalibrationTarget::AprilGrid(spec), std::invalid_argument);
  spec = AprilGridSpec();
  spec.tag_spacing = 0.0;
  EXPECT_THROW(CalibrationTarget::AprilGrid(spec), std::invalid_argument);
  spec = AprilGridSpec();
  spec.tag_rows = 0;
  EXPECT_THROW(CalibrationTarget::AprilGrid(spec), std::invalid_argument);
}

}  // namespace
}  // namespace mfns::host
