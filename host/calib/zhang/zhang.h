// Per-camera intrinsics by Zhang's method (cv::calibrateCamera): alpha_x, alpha_y, u0, v0 and
// kc1..kc5 (skew fixed at 0: OpenCV has none; kc5 = k3 fixed at 0 by default as the paper's
// Table 2), each view's pose and RMS, and 1-sigma from OpenCV's stdDeviationsIntrinsics
// (sqrt of diag((J^T J)^-1) times the residual variance sum r^2 / (2 N - p); OpenCV before 4.8
// divides by N - p, a sqrt(2) too large sigma that is corrected here).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "common/camera/camera.h"
#include "host/calib/core/calib_types.h"

namespace mfns::host {

struct ZhangOptions {
  bool fix_k3 = true;  // kc5 = 0 (Table 2); false frees it
};

struct ZhangView {
  Eigen::Matrix3d C_k_w = Eigen::Matrix3d::Identity();  // target (world) -> camera
  Eigen::Vector3d r_w_wk = Eigen::Vector3d::Zero();     // camera centre in w (m)
  std::vector<Eigen::Vector2d> residuals;               // predicted - observed (px), corner order
  double rms_px = 0.0;
};

struct ZhangResult {
  CameraIntrinsics camera;
  CameraParamVector sigma = CameraParamVector::Zero();  // CameraParam order; 0 where fixed
  std::vector<ZhangView> views;                          // input order
  double rms_px = 0.0;                                   // OpenCV's: sqrt(mean |residual|^2)
  int num_corners = 0;
};

// views: the corners of each image of one camera (each >= 4 corners, ids into target_points).
// Throws UserError with fewer than 3 views.
ZhangResult CalibrateZhang(const std::vector<std::vector<CornerObs>>& views,
                           const std::vector<Eigen::Vector3d>& target_points, int width, int height,
                           const ZhangOptions& options = {});

}  // namespace mfns::host
