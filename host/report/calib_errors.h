// A calibrated rig against the truth it was calibrated from: the Table-3-style numbers of
// issue 7 (per camera: estimate - truth of the rotation C_k_b and the position r_b_bk, with
// the calibration's 1-sigma). Cameras are matched by name.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "common/rig/rig.h"

namespace mfns::host {

struct CameraCalibError {
  std::string name;
  // 2-1-3 Euler angles (phi, theta, psi) of C_k_b: estimate - truth, deg, wrapped to +-180.
  // Near phi = +-90 deg (the paper's camera y) theta and psi are ill-conditioned: read
  // rotation_deg there.
  Eigen::Vector3d euler_error_deg = Eigen::Vector3d::Zero();
  Eigen::Vector3d euler_sigma_deg = Eigen::Vector3d::Zero();  // from the estimate's rig file
  // Small rotation e about the body axes with C_k_b_est = C_k_b_true * Exp(e), deg, and |e|.
  Eigen::Vector3d rotation_error_b_deg = Eigen::Vector3d::Zero();
  double rotation_deg = 0.0;
  Eigen::Vector3d position_error_mm = Eigen::Vector3d::Zero();  // r_b_bk estimate - truth
  Eigen::Vector3d position_sigma_mm = Eigen::Vector3d::Zero();
  double position_mm = 0.0;  // |position_error_mm|
  bool has_sigma = false;
};

// One entry per camera of `estimate` that `truth` also has (in the estimate's order). Throws
// UserError when no camera matches.
std::vector<CameraCalibError> CompareCalibration(const Rig& estimate, const Rig& truth);

// A rig with the cameras (and sigma, rig id) of `cameras` and the beacon map of `beacons`:
// what the flyer loads after a calibration (which has no beacons) and a survey.
Rig MergeRig(const Rig& cameras, const Rig& beacons);

}  // namespace mfns::host
