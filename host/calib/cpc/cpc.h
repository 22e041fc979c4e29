// The paper's checkerboard-fixed post-processing calibration (CPC, Section 4.1 and Appendix A),
// `--method paper`: the reference the joint calibration is measured against.
//
// Input: Zhang's per-camera intrinsics and per-image extrinsics (C_w_k, r_w_wk), the commanded
// turntable angles and the measured mount (r_p_pb: the paper measured the body origin's height
// with a caliper; C_p_b = I by machining).
//
// A.1 rotations. With C_w_t = C0 (I - [a]x) (a = alpha, beta, gamma: eq. A2) and
//   C_b_z = (I - [c]x) B0 (c = phi, theta, psi: eq. A3), the reference camera's image i gives
//   M_i = C0^T C_w_z(i) B0^T = (I - [a]x) N_i (I - [c]x),  N_i = C_t_p(main_i, aux_i) C_p_b,
//   which to first order (the paper's "higher-order terms neglected", A7 -> A8/A9) is linear:
//   M_i - N_i = -[a]x N_i - N_i [c]x.
//   The paper's A10 stacks, for an image turned about Zt only (N = A5), the elements (3,1),
//   (3,2), (1,3), (2,3) and for one turned about Xt only (N = Rx(omega), A9) the elements
//   (1,2), (1,3), (2,1), (3,1) (their nominal values are 0); images turned about both axes
//   (our kinematics: aux is the outer axis, C_t_p = Rx(aux) Rz(main)) use all nine elements.
//   C0, B0 are the nominal axis-aligned orientations (I in the paper after the alignment of
//   A.3; the nearest signed permutations of the closed-form hand-eye solution here, so a target
//   frame with z_w down, C_w_t ~ Rx(180 deg), works too). Least squares gives a and c.
//   A11/A12: C_b_k = (C_w_t C_t_b(i))^T C_w_k(i) for the other cameras, averaged over images.
// A.2 positions. A13-A16 for the reference camera, generalised to both axes:
//   r_w_wz(i) = r_w_wt + C_w_t C_t_p(i) r_p_pb + C_w_b(i) r_b_bz
//   solved for r_w_wt and r_b_bz by least squares with r_p_pb measured (the body origin and
//   r_b_bz,z are coupled: the paper's caliper measurement of r_w_wb,z); then A17/A18:
//   r_b_bk = C_w_b(i)^T (r_w_wk(i) - r_w_wb(i)), averaged over images.
// Sigma: each step's own least-squares scatter; the errors a step inherits from the previous
// (e.g. C_w_t's in C_b_x, the paper's remark in Section 5) are not propagated.
#pragma once

#include <string>
#include <vector>

#include "host/calib/core/calib_types.h"
#include "host/calib/core/kinematics.h"

namespace mfns::host {

struct CpcOptions {
  std::string reference_camera = "z";  // the camera whose C_b_k is near-nominal, seen at aux ~ 0
  bool paper_rows_only = true;         // A10's four elements for single-axis images (else all nine)
};

struct CpcStart {
  std::vector<CameraIntrinsics> intrinsics;         // Zhang's, per camera
  std::vector<CameraParamVector> sigma_intrinsics;  // Zhang's
  std::vector<Transform> view_T_w_k;                // Zhang's extrinsics per view
  Eigen::Matrix3d C0_w_t = Eigen::Matrix3d::Identity();  // nominal C_w_t
  Eigen::Matrix3d B0_b_ref = Eigen::Matrix3d::Identity();  // nominal C_b_k of the reference camera
};

// Throws UserError when the reference camera is missing or has fewer than 3 turntable images.
RigCalibration SolveCpc(const CalibInput& in, const CpcStart& start, const CpcOptions& options);

// The linear model of A8/A9 (and its two-axis generalisation): d vec9(M - N) / d(a, c), 9x6,
// rows in row-major element order (1,1), (1,2), ..., (3,3).
Eigen::Matrix<double, 9, 6> SmallAngleDesign(const Eigen::Matrix3d& N);

}  // namespace mfns::host
