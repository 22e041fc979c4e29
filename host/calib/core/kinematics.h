// Turntable kinematics of docs/calib-dataset.md, written once for every calibration method.
//
// Inner main axis Zt carries the platform; the outer auxiliary axis Xt tilts the inner
// assembly; both pass through Ot. Platform attitude C_t_p = Rx(aux) Rz(main) with active
// rotations (frame form R1(aux)^T R3(main)^T). Body of a turntable image:
//   C_w_b = C_w_t C_t_p C_p_b,   r_w_wb = r_w_wt + C_w_t C_t_p r_p_pb.
// Camera k of the rig: C_w_k = C_w_b C_k_b^T, r_w_wk = r_w_wb + C_w_b r_b_bk.
// The simulator's TurntablePose (scenario.h) is the generator's copy;
// host/testing/turntable_contract_test.cc keeps the two equal.
#pragma once

#include <Eigen/Core>

namespace mfns::host {

// A rigid transform as the calibration uses it: C_a_b and r_a_ab (m).
struct Transform {
  Eigen::Matrix3d C = Eigen::Matrix3d::Identity();
  Eigen::Vector3d r = Eigen::Vector3d::Zero();
};

// The turntable in the world and the body on the platform.
struct TurntableMount {
  Eigen::Matrix3d C_w_t = Eigen::Matrix3d::Identity();
  Eigen::Vector3d r_w_wt = Eigen::Vector3d::Zero();
  Eigen::Matrix3d C_p_b = Eigen::Matrix3d::Identity();
  Eigen::Vector3d r_p_pb = Eigen::Vector3d::Zero();
};

// C_t_p for turntable angles (rad).
Eigen::Matrix3d PlatformRotation(double main_rad, double aux_rad);

// Body in the world (C_w_b, r_w_wb) for turntable angles (rad).
Transform BodyInWorld(const TurntableMount& m, double main_rad, double aux_rad);

// Camera k in the world (C_w_k, r_w_wk) from the body in the world and the camera's C_k_b,
// r_b_bk.
Transform CameraInWorld(const Transform& body_in_world, const Eigen::Matrix3d& C_k_b, const Eigen::Vector3d& r_b_bk);

// Angle (rad, 0..pi) of the rotation C.
double RotationAngle(const Eigen::Matrix3d& C);

// The signed permutation matrix (a rotation whose entries are 0 or +-1) nearest to C: the
// nominal orientation around which a small-angle model linearises.
Eigen::Matrix3d NearestAxisAligned(const Eigen::Matrix3d& C);

}  // namespace mfns::host
