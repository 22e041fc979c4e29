// The physical limit of navigation accuracy (DESIGN.md, "Error sources and the limit"): the
// Cramér-Rao bound of the body pose for a frame set, the inverse of the Fisher information
// J^T J / sigma^2 of the multi-camera model (eq. 2) over the beacons each camera sees, with
// independent Gaussian centroid noise sigma_px on u and v.
//
// Pose parametrisation: common/rig/rig.h PoseDelta = [dr_w (m); dtheta_b (rad)]. The bound is
// also given per axis for the quantities the CSVs report: position r_w_wb (m) and the Euler
// angles of C_b_w (rad), propagated through the Euler Jacobian (central differences).
#pragma once

#include <Eigen/Core>
#include <array>
#include <vector>

#include "common/rig/rig.h"

namespace mfns::host {

struct VisibleBeacon {
  int camera = 0;
  int beacon = 0;
  Eigen::Vector2d uv_px = Eigen::Vector2d::Zero();  // true image position
};

// Beacons each camera sees (host/sim/render/visibility.h SightBeacon: facing the camera, in
// front, inside the image shrunk by margin_px, not a distortion ghost); beacons listed in
// `occluded` are skipped.
std::vector<VisibleBeacon> VisibleBeacons(const Rig& rig, const BodyPose& pose, double margin_px = 0.0,
                                          const std::vector<int>& occluded = {});

struct PoseBound {
  bool valid = false;  // false when the Fisher information is singular (< 3 beacons, degenerate)
  int num_beacons = 0;
  std::array<int, limits::kMaxCameras> per_camera{};
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();  // PoseDelta
  Eigen::Vector3d sigma_position = Eigen::Vector3d::Zero();  // m, world axes
  Eigen::Vector3d sigma_euler = Eigen::Vector3d::Zero();     // rad: roll, pitch, yaw of C_b_w
};

PoseBound PoseCramerRao(const Rig& rig, const BodyPose& pose, const std::vector<VisibleBeacon>& seen,
                        double sigma_px);

// d(phi, theta, psi of C_b_w) / d(dtheta_b) at pose, by central differences.
Eigen::Matrix3d EulerJacobian(const BodyPose& pose);

}  // namespace mfns::host
