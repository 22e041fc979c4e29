// A calibration against the truth of a simulated dataset: the error of every parameter and
// how many sigma it is, for the tests, the report and docs/calibration.md.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "common/rig/rig.h"
#include "host/calib/core/calib_types.h"
#include "host/calib/core/kinematics.h"

namespace mfns::host {

// One scalar parameter: estimate - truth, in the parameter's unit, and its 1-sigma (0: none).
struct ParamError {
  std::string name;  // e.g. "z.alpha_x", "z.rot_b.x", "z.r_b_bk.y", "C_w_t.rot_w.z"
  std::string unit;  // px, 1, deg, mm
  double error = 0.0;
  double sigma = 0.0;
};

struct CameraError {
  std::string name;
  double rotation_deg = 0.0;  // angle of C_k_b_est C_k_b_true^T
  double position_mm = 0.0;   // |r_b_bk_est - r_b_bk_true|
};

struct RigErrors {
  std::vector<CameraError> cameras;
  double C_w_t_deg = 0.0, r_w_wt_mm = 0.0;  // only with a true mount
  std::vector<ParamError> params;            // every estimated scalar
};

// Cameras are matched by name; a camera missing from the truth is skipped. truth_mount may be
// null. Rotation errors are small rotations about the body axes (C_k_b) or world axes (C_w_t):
// C_b_k_true = Exp(e) C_b_k_est, so they compare with CameraResult::sigma_rotation.
RigErrors CompareRig(const RigCalibration& rig, const Rig& truth, const TurntableMount* truth_mount);

}  // namespace mfns::host
