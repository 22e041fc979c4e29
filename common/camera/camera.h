// Camera model (DESIGN.md, "Camera model"): pinhole with alpha_x, alpha_y, skew gamma and
// principal point (u0, v0), distortion kc1..kc5 in Bouguet's order = OpenCV's (k1, k2, p1, p2,
// k3) on normalised coordinates. Pixel centres at integer coordinates (OpenCV), so the image
// covers [-0.5, width - 0.5] x [-0.5, height - 0.5].
//
//   x = X/Z, y = Y/Z,  r2 = x^2 + y^2,  radial = 1 + k1 r2 + k2 r2^2 + k3 r2^3
//   xd = x radial + 2 p1 x y + p2 (r2 + 2 x^2)
//   yd = y radial + p1 (r2 + 2 y^2) + 2 p2 x y
//   u = alpha_x xd + gamma yd + u0,   v = alpha_y yd + v0            (paper eq. 1, first row)
//
// The skew gamma is in pixels as in the paper (Bouguet's alpha_c = gamma / alpha_x). OpenCV's
// model has no skew: exports require gamma = 0 or say so.
// No heap, no exceptions: usable on the flyer.
#pragma once

#include <Eigen/Core>
#include <array>

namespace mfns {

// Order of the intrinsic parameter vector, used by every parameter Jacobian.
enum CameraParam : int {
  kAlphaX = 0, kAlphaY, kSkew, kU0, kV0, kKc1, kKc2, kKc3, kKc4, kKc5, kNumCameraParams
};

using CameraParamVector = Eigen::Matrix<double, kNumCameraParams, 1>;

struct CameraIntrinsics {
  int width = 0;   // px
  int height = 0;  // px
  double alpha_x = 0.0;  // px
  double alpha_y = 0.0;  // px
  double skew = 0.0;     // gamma, px
  double u0 = 0.0;       // px
  double v0 = 0.0;       // px
  std::array<double, 5> kc{};  // k1, k2, p1, p2, k3

  CameraParamVector ToVector() const;
  void SetFromVector(const CameraParamVector& p);
};

enum class ProjectStatus : unsigned char {
  kOk = 0,
  kBehindCamera,  // Z <= min depth: no image
  kNonFinite,     // NaN/Inf input or result
};

enum class UnprojectStatus : unsigned char {
  kOk = 0,
  kNotConverged,  // the iteration bound was reached above tolerance (strong distortion)
  kNonFinite,
};

// Normalised (x, y) -> distorted (xd, yd); J_xd_x (optional) is d(xd, yd)/d(x, y).
Eigen::Vector2d Distort(const CameraIntrinsics& cam, const Eigen::Vector2d& x_n,
                        Eigen::Matrix2d* J_xd_x = nullptr);

// p_k: a point in camera frame k (any length unit). Outputs uv_px; optional Jacobians
// d(u, v)/d(p_k) and d(u, v)/d(intrinsics) in CameraParam order. Outputs are untouched
// unless the status is kOk.
ProjectStatus Project(const CameraIntrinsics& cam, const Eigen::Vector3d& p_k,
                      Eigen::Vector2d* uv_px,
                      Eigen::Matrix<double, 2, 3>* J_uv_p = nullptr,
                      Eigen::Matrix<double, 2, kNumCameraParams>* J_uv_params = nullptr);

// Pixel -> undistorted normalised coordinates (x, y) = (X/Z, Y/Z) by Newton iteration on the
// distortion, bounded by limits::kMaxUnprojectIterations; converged when re-projecting the
// result lands within tol_px of uv_px.
UnprojectStatus Unproject(const CameraIntrinsics& cam, const Eigen::Vector2d& uv_px,
                          Eigen::Vector2d* x_n, double tol_px = 1e-7);

// True when uv lies inside the image shrunk by margin_px on every side.
bool InImage(const CameraIntrinsics& cam, const Eigen::Vector2d& uv_px, double margin_px = 0.0);

}  // namespace mfns
