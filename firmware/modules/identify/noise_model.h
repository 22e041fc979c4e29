// The tracker's noise model: how much an image measurement errs and what an angle is in pixels
// (issue 13 item 5). One value built from the rig at Tracker::Reset (pixels per radian) and
// completed from the options of each frame set (centroid noise, map error), so that every test
// of the tracker reads the same three numbers instead of re-deriving them from the options.
//
// Inputs: the rig's cameras (focal lengths, px/rad) and TrackOptions' solve.sigma_px and
// map_error_px (px, 1-sigma per image axis). Output: derived quantities, all in px or ratios.
// No state beyond the three numbers; no heap.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>

#include "common/rig/rig.h"

namespace mfns::fw {

// The rig's largest focal length (px/rad; 0 without a camera): pixel gates are sized for it, so
// an angle converted with it is never underestimated on any camera.
inline double LargestFocalPx(const Rig& rig) {
  double px_per_rad = 0.0;
  for (int k = 0; k < rig.num_cameras; ++k)
    px_per_rad = std::max({px_per_rad, rig.cameras[static_cast<std::size_t>(k)].intrinsics.alpha_x,
                           rig.cameras[static_cast<std::size_t>(k)].intrinsics.alpha_y});
  return px_per_rad;
}

// A residual bound (px) that must also hold a beacon map error of map_px (1-sigma, px) seen
// `sigmas` times: the two add in quadrature (independent errors).
inline double GrowForMapError(double bound_px, double sigmas, double map_px) {
  return std::hypot(bound_px, sigmas * map_px);
}

struct NoiseModel {
  double px_per_rad = 0.0;    // the rig's largest focal length (LargestFocalPx), px/rad
  double sigma_px = 0.0;      // blob centroid noise, px 1-sigma per axis (the solve's)
  double map_error_px = 0.0;  // the beacon map's error seen as image noise, px 1-sigma

  // Built at Reset: the rig fixes the pixel scale; the image noise comes with the options.
  static NoiseModel OfRig(const Rig& rig) {
    NoiseModel n;
    n.px_per_rad = LargestFocalPx(rig);
    return n;
  }
  // This model with the image noise of a frame set's options (px, 1-sigma).
  NoiseModel WithImageNoise(double centroid_sigma_px, double map_px) const {
    NoiseModel n = *this;
    n.sigma_px = centroid_sigma_px;
    n.map_error_px = map_px;
    return n;
  }

  // map_error_px / sigma_px (0 without a map error): the solve's covariance is for the
  // centroid noise alone; the map's share of a pose's 1-sigma is this times it.
  double MapToCentroidRatio() const {
    return map_error_px > 0.0 && sigma_px > 0.0 ? map_error_px / sigma_px : 0.0;
  }
  // A pose's whole 1-sigma (centroid noise and map error) over the solve's (centroid only).
  double TotalToCentroid() const { return std::hypot(1.0, MapToCentroidRatio()); }
  // The expected per-axis residual of a true match (px, 1-sigma).
  double ResidualSigmaPx() const { return std::hypot(sigma_px, map_error_px); }
  // Its variance (px^2), the unit of a chi-square over the residuals.
  double ResidualVariancePx2() const { return sigma_px * sigma_px + map_error_px * map_error_px; }
};

}  // namespace mfns::fw
