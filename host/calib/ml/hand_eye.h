// Closed-form rig from per-image camera poses and the turntable's commanded angles: the
// robot-world/hand-eye problem A X = Z B with a shared turntable-world transform. Needs no
// small-angle model and no prior alignment of the turntable with the target.
//
// Each turntable image of camera k gives C_w_k, r_w_wk (Zhang's extrinsics, inverted) and
//   C_w_k C_k_b = C_w_t C_t_b            (C_t_b = C_t_p(main, aux) C_p_b)
//   r_w_wt + C_w_b r_b_bk = r_w_wk - C_w_t C_t_p r_p_pb
// The rotations are linear in (C_w_t, C_k_b for every k) jointly: vec(A X) = (I (x) A) vec(X),
// vec(X B) = (B^T (x) I) vec(X); the null vector of the stacked 9-row blocks (SVD), scaled to
// det C_w_t = 1 and each 3x3 block projected to SO(3), is the start. Then the translations by
// linear least squares with those rotations.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "host/calib/core/calib_types.h"
#include "host/calib/core/kinematics.h"

namespace mfns::host {

struct HandEyeView {
  int camera = 0;
  double main = 0.0, aux = 0.0;  // rad (commanded)
  Transform T_w_k;               // C_w_k, r_w_wk of this image
};

struct HandEyeResult {
  Eigen::Matrix3d C_w_t = Eigen::Matrix3d::Identity();
  Eigen::Vector3d r_w_wt = Eigen::Vector3d::Zero();
  std::vector<Eigen::Matrix3d> C_k_b;  // per camera (identity for a camera with no views)
  std::vector<Eigen::Vector3d> r_b_bk;
  std::vector<bool> solved;            // per camera: had turntable views
  double rotation_rms = 0.0;           // rad: RMS angle of C_w_k C_k_b (C_w_t C_t_b)^T
  double position_rms = 0.0;           // m: RMS of the translation equation's residual
};

// Throws UserError when fewer than 2 views are given or the rotations are degenerate.
HandEyeResult SolveHandEyeLinear(const std::vector<HandEyeView>& views, int num_cameras, const Eigen::Matrix3d& C_p_b,
                                 const Eigen::Vector3d& r_p_pb);

// OpenCV's cv::calibrateRobotWorldHandEye (Shah's method) for ONE camera's views: C_w_t,
// r_w_wt, C_k_b, r_b_bk of that camera alone (camera index in the result is views[0].camera).
HandEyeResult SolveHandEyeOpenCv(const std::vector<HandEyeView>& views, int num_cameras, const Eigen::Matrix3d& C_p_b,
                                 const Eigen::Vector3d& r_p_pb);

}  // namespace mfns::host
