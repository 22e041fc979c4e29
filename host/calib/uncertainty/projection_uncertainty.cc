#include "host/calib/uncertainty/projection_uncertainty.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "common/rotation/rotation.h"

namespace mfns::host {

double ProjectionSigmaPx(const CameraResult& cam, RayFrame frame, const Eigen::Vector2d& uv_px) {
  Eigen::Vector2d x_n;
  if (Unproject(cam.intrinsics, uv_px, &x_n) != UnprojectStatus::kOk) return std::nan("");
  const Eigen::Vector3d v(x_n.x(), x_n.y(), 1.0);
  Eigen::Vector2d uv;
  Eigen::Matrix<double, 2, 3> J_uv_p;
  Eigen::Matrix<double, 2, kNumCameraParams> J_uv_intr;
  if (Project(cam.intrinsics, v, &uv, &J_uv_p, &J_uv_intr) != ProjectStatus::kOk) return std::nan("");
  constexpr int n = kNumCameraParams + 3;  // intrinsics, then the rotation phi
  Eigen::Matrix<double, 2, n> J = Eigen::Matrix<double, 2, n>::Zero();
  J.leftCols<kNumCameraParams>() = J_uv_intr;
  if (frame == RayFrame::kBody) J.rightCols<3>() = J_uv_p * Skew(v) * cam.C_k_b;
  const Eigen::Matrix2d c = J * cam.covariance.topLeftCorner<n, n>() * J.transpose();
  return std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(c).eigenvalues()[1]));
}

Eigen::Vector2d GridCellCentre(const CameraIntrinsics& cam, int cols, int rows, int col, int row) {
  return {(col + 0.5) * cam.width / cols - 0.5, (row + 0.5) * cam.height / rows - 0.5};
}

ProjectionSigmaGrid ProjectionSigmaMap(const CameraResult& cam, RayFrame frame, int cols, int rows) {
  ProjectionSigmaGrid g;
  g.cols = cols;
  g.rows = rows;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      g.sigma_px.push_back(ProjectionSigmaPx(cam, frame, GridCellCentre(cam.intrinsics, cols, rows, c, r)));
  return g;
}

}  // namespace mfns::host
