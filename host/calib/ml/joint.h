// The joint maximum-likelihood calibration (`--method ml`): one Ceres problem over every corner
// of every image of every camera.
//
// Parameters: per camera the intrinsics (alpha_x, alpha_y, u0, v0, kc1..kc4, kc5 unless fixed;
// skew fixed at 0 unless freed), C_k_b and r_b_bk; the turntable-world transform C_w_t, r_w_wt;
// per turntable image its true (main, aux) angles with a Gaussian prior at the commanded
// values (1-sigma CalibInput::angle_sigma, 8 arcsec); per free (hand-held) image a free camera
// pose. Residuals: the reprojection error of each corner divided by its camera's pixel sigma
// (re-estimated from the residuals: sqrt(sum r^2 / (2 N - p)) without the outliers, so the
// prior and the images weigh as their noise says), under a Huber loss at min(huber_px,
// robust_sigmas x the camera's pixel sigma); plus the angle priors. A corner beyond
// outlier_sigmas x its camera's sigma is an outlier: left out of the sigma estimate, its pull
// bounded by the Huber loss, and listed (RigCalibration::outliers, CameraResult::outliers).
//
// Gauge (docs/calib-dataset.md): C_p_b and r_p_pb are fixed at CalibInput's values. Images
// cannot separate r_p_pb from a common shift of every camera's r_b_bk (they see only
// r_p_pb + r_b_bk), nor C_p_b from a common rotation of every C_k_b together with offsets of
// the angle zeros; the body frame is defined by the machined mount instead. Everything else
// is observable when the turntable turns about both axes.
//
// 1-sigma of every estimated parameter from ceres::Covariance (J^T J)^-1 of the whitened
// problem. Rotations: sigma of small rotations about the body axes (C_k_b) or world axes
// (C_w_t), and of the 2-1-3 Euler angles by first-order propagation.
#pragma once

#include <iosfwd>
#include <vector>

#include "common/camera/camera.h"
#include "host/calib/core/calib_types.h"
#include "host/calib/core/kinematics.h"

namespace mfns::host {

struct MlOptions {
  bool fix_k3 = true;
  bool fix_skew = true;
  double huber_px = 1.0;        // 0: plain least squares
  double robust_sigmas = 4.0;   // the Huber loss starts here (in the camera's pixel sigmas) when below huber_px
  double outlier_sigmas = 5.0;  // |residual| beyond this many pixel sigmas: an outlier corner
  int max_iterations = 100;
  int reweight_passes = 3;   // solve, re-estimate pixel sigma, solve again (at most this many)
  bool covariance = true;
  std::ostream* progress = nullptr;  // one line per pass and per iteration when set
};

// The start: intrinsics per camera, the rig and turntable from the closed form, a pose per
// free image (indexed like CalibInput::views; turntable entries unused), and a first pixel
// sigma per camera.
struct MlStart {
  std::vector<CameraIntrinsics> intrinsics;
  std::vector<Eigen::Matrix3d> C_k_b;
  std::vector<Eigen::Vector3d> r_b_bk;
  Eigen::Matrix3d C_w_t = Eigen::Matrix3d::Identity();
  Eigen::Vector3d r_w_wt = Eigen::Vector3d::Zero();
  std::vector<Transform> view_T_w_k;
  std::vector<double> sigma_px;
};

// Throws UserError when Ceres fails outright. Cameras with no turntable image keep their
// start C_k_b, r_b_bk with zero sigma (a note says so).
RigCalibration SolveJointMl(const CalibInput& in, const MlStart& start, const MlOptions& options);

// Residuals of every view under a given rig (for methods without their own): turntable views
// through the kinematics at the commanded angles, free views at view_T_w_k.
std::vector<ViewResidual> RigResiduals(const CalibInput& in, const RigCalibration& rig,
                                       const std::vector<Transform>& view_T_w_k);

// Per-camera and overall residual RMS (rig->cameras[k].rms_px, rig->rms_px) from
// rig->residuals (non-finite residuals skipped). rig->cameras must have in.cameras' size.
void SetResidualRms(const CalibInput& in, RigCalibration* rig);

// Appends every turntable view's angles to rig->angles as commanded (estimate = command), for
// methods that do not estimate them.
void AppendCommandedAngles(const CalibInput& in, RigCalibration* rig);

// sigma of the 2-1-3 Euler angles of C_k_b from the covariance of small rotations about the
// body axes (C_b_k <- Exp(phi) C_b_k), by central differences.
Eigen::Vector3d EulerSigma(const Eigen::Matrix3d& C_k_b, const Eigen::Matrix3d& cov_phi_b);

}  // namespace mfns::host
