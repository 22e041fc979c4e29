// NoiseModel (noise_model.h): the pixel scale from the rig, the derived noise quantities, and
// that TrackOptions' map-error allowance grows its bounds by the same rule.
#include "firmware/modules/identify/noise_model.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "common/rig/paper_rig.h"
#include "firmware/modules/identify/tracker.h"

namespace mfns::fw {
namespace {

TEST(NoiseModelTest, PixelScaleIsTheLargestFocalLength) {
  Rig rig = PaperRig();
  double f = 0.0;
  for (int k = 0; k < rig.num_cameras; ++k)
    f = std::max({f, rig.cameras[static_cast<std::size_t>(k)].intrinsics.alpha_x,
                  rig.cameras[static_cast<std::size_t>(k)].intrinsics.alpha_y});
  EXPECT_EQ(NoiseModel::OfRig(rig).px_per_rad, f);
  EXPECT_EQ(LargestFocalPx(rig), f);
  rig.cameras[1].intrinsics.alpha_y = 4.0 * f;
  EXPECT_EQ(NoiseModel::OfRig(rig).px_per_rad, 4.0 * f);
  rig.num_cameras = 0;
  EXPECT_EQ(NoiseModel::OfRig(rig).px_per_rad, 0.0);
}

TEST(NoiseModelTest, DerivedQuantities) {
  const NoiseModel clean = NoiseModel{1600.0, 0.0, 0.0}.WithImageNoise(0.15, 0.0);
  EXPECT_EQ(clean.px_per_rad, 1600.0);  // kept from the rig
  EXPECT_EQ(clean.MapToCentroidRatio(), 0.0);
  EXPECT_EQ(clean.TotalToCentroid(), 1.0);
  EXPECT_DOUBLE_EQ(clean.ResidualSigmaPx(), 0.15);
  const NoiseModel surveyed = clean.WithImageNoise(0.15, 1.2);
  EXPECT_DOUBLE_EQ(surveyed.MapToCentroidRatio(), 8.0);
  EXPECT_DOUBLE_EQ(surveyed.TotalToCentroid(), std::sqrt(65.0));
  EXPECT_DOUBLE_EQ(surveyed.ResidualSigmaPx(), std::hypot(0.15, 1.2));
  EXPECT_DOUBLE_EQ(surveyed.ResidualVariancePx2(), 0.15 * 0.15 + 1.2 * 1.2);
  // No centroid noise: no ratio (the covariance would be zero anyway).
  EXPECT_EQ(clean.WithImageNoise(0.0, 1.2).MapToCentroidRatio(), 0.0);
}

TEST(NoiseModelTest, TrackOptionsAllowForMapErrorUsesTheSameRule) {
  TrackOptions o;
  const TrackOptions before = o;
  o.AllowForMapError(1.3);
  EXPECT_EQ(o.refine_gate_px, GrowForMapError(before.refine_gate_px, 4.0, 1.3));
  EXPECT_EQ(o.max_rms_px, GrowForMapError(before.max_rms_px, 2.0, 1.3));
  EXPECT_EQ(o.map_error_px, 1.3);
  EXPECT_EQ(o.MapToCentroidRatio(), NoiseModel{}.WithImageNoise(o.solve.sigma_px, 1.3).MapToCentroidRatio());
}

}  // namespace
}  // namespace mfns::fw
