// Projection uncertainty of a calibrated camera (issue 18 item 4, as mrcal draws it): how far,
// 1-sigma, the calibration's own uncertainty moves the pixel at which a fixed ray lands.
//
// For a pixel q: the ray v = Unproject(estimate, q), then q' = Project(intrinsics', p') with the
// parameters drawn from their covariance; to first order cov(q') = J Sigma J^T. The reported
// sigma is the 1-sigma along the worst direction: sqrt of the largest eigenvalue of the 2x2
// covariance (px). Two rays:
//   kCamera: the ray fixed in the camera frame, p' = v; the intrinsics' covariance alone
//            (mrcal's single-camera map).
//   kBody:   the ray fixed in the body frame, p' = C_k_b' C_b_k v with C_b_k' = Exp(phi) C_b_k
//            (dp'/dphi = [v]x C_k_b); intrinsics and C_k_b jointly. These are the rays the
//            flyer navigates with; a principal-point error that C_k_b absorbs (they are strongly
//            correlated on a turntable) does not move them, so this is usually the smaller.
// r_b_bk does not enter: the beacons are metres away, a calibrated r_b_bk is good to 0.1 mm.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "common/camera/camera.h"
#include "host/calib/core/calib_types.h"

namespace mfns::host {

enum class RayFrame { kCamera, kBody };

// 1-sigma (px, worst direction) at pixel uv_px of camera `cam` (C_k_b and the joint
// covariance CameraResult::covariance are used); NaN where the pixel does not unproject.
double ProjectionSigmaPx(const CameraResult& cam, RayFrame frame, const Eigen::Vector2d& uv_px);

// The sigma over a cols x rows grid of cells covering the image, each at its cell's centre
// (GridCellCentre); row-major from the top-left cell.
struct ProjectionSigmaGrid {
  int cols = 0, rows = 0;
  std::vector<double> sigma_px;  // rows * cols
  double At(int col, int row) const { return sigma_px[static_cast<std::size_t>(row * cols + col)]; }
};
ProjectionSigmaGrid ProjectionSigmaMap(const CameraResult& cam, RayFrame frame, int cols, int rows);

// The centre of a grid cell in pixels (pixel centres at integers):
// u = (col + 0.5) width / cols - 0.5, v likewise.
Eigen::Vector2d GridCellCentre(const CameraIntrinsics& cam, int cols, int rows, int col, int row);

}  // namespace mfns::host
