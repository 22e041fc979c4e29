// Projection uncertainty of a calibrated camera (issue 18 item 4, as mrcal draws it): how far,
// 1-sigma, the calibration's own uncertainty moves the pixel at which a fixed ray lands.
//
// For a pixel q: the ray v = Unproject(mean intrinsics, q) in the camera frame, then
// q' = Project(intrinsics, v) with the intrinsics drawn from their covariance; to first order
// cov(q') = J Sigma J^T with J = d(u, v)/d(intrinsics) at v (common/camera/camera.h). The
// reported sigma is the 1-sigma along the worst direction: sqrt of the largest eigenvalue of the
// 2x2 covariance (px). Only the intrinsics' block of the covariance is used: the ray is fixed in
// the camera frame (the camera-to-body rotation's uncertainty is C_k_b's sigma, reported apart).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "common/camera/camera.h"

namespace mfns::host {

using IntrinsicsCovariance = Eigen::Matrix<double, kNumCameraParams, kNumCameraParams>;

// 1-sigma (px, worst direction) at pixel uv_px; NaN where the pixel does not unproject.
double ProjectionSigmaPx(const CameraIntrinsics& cam, const IntrinsicsCovariance& cov, const Eigen::Vector2d& uv_px);

// The sigma over a cols x rows grid of cells covering the image, each at its cell's centre
// (u = (i + 0.5) width / cols - 0.5, v likewise); row-major from the top-left cell.
struct ProjectionSigmaGrid {
  int cols = 0, rows = 0;
  std::vector<double> sigma_px;  // rows * cols
  double At(int col, int row) const { return sigma_px[static_cast<std::size_t>(row * cols + col)]; }
};
ProjectionSigmaGrid ProjectionSigmaMap(const CameraIntrinsics& cam, const IntrinsicsCovariance& cov, int cols,
                                       int rows);

// The centre of a grid cell in pixels (pixel centres at integers).
Eigen::Vector2d GridCellCentre(const CameraIntrinsics& cam, int cols, int rows, int col, int row);

}  // namespace mfns::host
