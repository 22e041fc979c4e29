#include "host/calib/uncertainty/projection_uncertainty.h"

#include <Eigen/Eigenvalues>
#include <cmath>

namespace mfns::host {

double ProjectionSigmaPx(const CameraIntrinsics& cam, const IntrinsicsCovariance& cov, const Eigen::Vector2d& uv_px) {
  Eigen::Vector2d x_n;
  if (Unproject(cam, uv_px, &x_n) != UnprojectStatus::kOk) return std::nan("");
  Eigen::Vector2d uv;
  Eigen::Matrix<double, 2, kNumCameraParams> J;
  if (Project(cam, Eigen::Vector3d(x_n.x(), x_n.y(), 1.0), &uv, nullptr, &J) != ProjectStatus::kOk) return std::nan("");
  const Eigen::Matrix2d c = J * cov * J.transpose();
  return std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(c).eigenvalues()[1]));
}

Eigen::Vector2d GridCellCentre(const CameraIntrinsics& cam, int cols, int rows, int col, int row) {
  return {(col + 0.5) * cam.width / cols - 0.5, (row + 0.5) * cam.height / rows - 0.5};
}

ProjectionSigmaGrid ProjectionSigmaMap(const CameraIntrinsics& cam, const IntrinsicsCovariance& cov, int cols,
                                       int rows) {
  ProjectionSigmaGrid g;
  g.cols = cols;
  g.rows = rows;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      g.sigma_px.push_back(ProjectionSigmaPx(cam, cov, GridCellCentre(cam, cols, rows, c, r)));
  return g;
}

}  // namespace mfns::host
