// The data every calibration method shares: what was observed (corners per image, turntable
// angles) and what a method returns (the rig, the turntable-world transform, 1-sigma,
// residuals). Frames and kinematics: docs/calib-dataset.md and core/kinematics.h.
//
// Units: SI inside (m, rad); files carry mm and deg. Frames: w target (world), t turntable,
// p platform, b body, k camera. C_a_b maps b coordinates to a; r_c_ab is a -> b in frame c.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "common/camera/camera.h"

namespace mfns::host {

enum class ImageKind : unsigned char { kTurntable, kFree };
const char* ToString(ImageKind k);

// One detected target corner: its id (docs/calib-dataset.md) and image position (px, pixel
// centres at integers).
struct CornerObs {
  int id = 0;
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();
};

// The usable corners of one image.
struct ViewObservation {
  int camera = 0;          // index into CalibInput::cameras
  std::string image;       // file stem, e.g. "003"
  ImageKind kind = ImageKind::kTurntable;
  double main_cmd = 0.0;   // commanded turntable angles (rad), turntable images only
  double aux_cmd = 0.0;
  std::vector<CornerObs> corners;
  // True when the target's symmetry leaves the corner ids defined only up to the 180-degree
  // rotation of the board (id -> N - 1 - id); core/orientation.h resolves it.
  bool orientation_ambiguous = false;
};

struct CameraInfo {
  std::string name;  // "x", "y", "z", ...
  int width = 0;     // px
  int height = 0;
};

// An image that no method uses, and why.
struct SkippedImage {
  std::string camera;
  std::string image;
  std::string reason;
};

// Everything a method needs. target_points[id] is corner id's position in w (m, z = 0).
struct CalibInput {
  std::vector<CameraInfo> cameras;
  std::vector<Eigen::Vector3d> target_points;
  std::vector<ViewObservation> views;
  std::vector<SkippedImage> skipped;
  // The mount (the gauge, docs/calib-dataset.md): body in the platform frame. Images cannot
  // tell r_p_pb from a common shift of every r_b_bk, so it is given (measured), not solved.
  Eigen::Matrix3d C_p_b = Eigen::Matrix3d::Identity();
  Eigen::Vector3d r_p_pb = Eigen::Vector3d::Zero();
  double angle_sigma = 8.0 / 3600.0 * 3.14159265358979323846 / 180.0;  // turntable, rad 1-sigma
};

// Reprojection residuals of one image under a method's final model.
struct ViewResidual {
  int view = 0;  // index into CalibInput::views
  std::vector<int> ids;
  std::vector<Eigen::Vector2d> uv;        // observed (px)
  std::vector<Eigen::Vector2d> residual;  // predicted - observed (px)
  double rms_px = 0.0;                    // sqrt(mean |residual|^2)
};

// A turntable image's angles as the method estimated them (ml) or used them (others).
struct AngleResult {
  int view = 0;
  double main_cmd = 0.0, aux_cmd = 0.0;  // rad
  double main_est = 0.0, aux_est = 0.0;  // rad
  double main_sigma = 0.0, aux_sigma = 0.0;
};

// A camera's calibrated state as the covariances order it: the intrinsics (CameraParam order:
// px, then the dimensionless kc), the small rotation phi of C_b_k about the body axes
// (C_b_k <- Exp(phi) C_b_k, rad) and r_b_bk (m).
inline constexpr int kStateRotation = kNumCameraParams;
inline constexpr int kStatePosition = kNumCameraParams + 3;
inline constexpr int kCameraStateSize = kNumCameraParams + 6;
using CameraStateCovariance = Eigen::Matrix<double, kCameraStateSize, kCameraStateSize>;

struct CameraResult {
  std::string name;
  CameraIntrinsics intrinsics;
  Eigen::Matrix3d C_k_b = Eigen::Matrix3d::Identity();
  Eigen::Vector3d r_b_bk = Eigen::Vector3d::Zero();
  // 1-sigma; zero where a parameter is fixed or the method gives none.
  CameraParamVector sigma_intrinsics = CameraParamVector::Zero();  // CameraParam order
  Eigen::Vector3d sigma_rotation = Eigen::Vector3d::Zero();  // rad, small rotations about body axes
  Eigen::Vector3d sigma_euler = Eigen::Vector3d::Zero();     // rad, of C_k_b's 2-1-3 Euler angles
  Eigen::Vector3d sigma_r_b_bk = Eigen::Vector3d::Zero();    // m
  // Joint covariance of the camera state (order above); rows and columns of fixed parameters
  // are zero, and all of it when the method gives no covariance (paper, opencv-handeye).
  CameraStateCovariance covariance = CameraStateCovariance::Zero();
  double rms_px = 0.0;  // over all of the camera's residuals
  // ml: the per-axis corner noise estimated from the residuals (sqrt(sum r^2 / dof), outliers
  // left out, dof = residual components - parameters; the weights and so the covariance use
  // it) and the number of outlier corners; 0 for methods without it.
  double pixel_sigma = 0.0;  // px
  double pixel_sigma_dof = 0.0;
  int outliers = 0;
};

// A corner whose residual is far beyond its camera's noise (ml: |residual| > 5 pixel_sigma;
// its weight is cut by the robust loss).
struct OutlierCorner {
  int view = 0;                                        // index into CalibInput::views
  int id = 0;                                          // corner id
  Eigen::Vector2d residual = Eigen::Vector2d::Zero();  // predicted - observed (px)
  double sigmas = 0.0;                                 // |residual| / pixel_sigma
};

struct RigCalibration {
  std::string method;  // "ml", "paper", "opencv-handeye"
  std::vector<CameraResult> cameras;  // CalibInput::cameras order
  Eigen::Matrix3d C_w_t = Eigen::Matrix3d::Identity();
  Eigen::Vector3d r_w_wt = Eigen::Vector3d::Zero();
  Eigen::Vector3d sigma_C_w_t = Eigen::Vector3d::Zero();  // rad, small rotations about w axes
  Eigen::Vector3d sigma_r_w_wt = Eigen::Vector3d::Zero();  // m
  Eigen::Matrix3d C_p_b = Eigen::Matrix3d::Identity();  // the gauge used (fixed)
  Eigen::Vector3d r_p_pb = Eigen::Vector3d::Zero();
  std::vector<ViewResidual> residuals;
  std::vector<AngleResult> angles;
  std::vector<OutlierCorner> outliers;  // ml; largest first
  double rms_px = 0.0;
  std::vector<std::string> notes;  // what was fixed and why, warnings
};

}  // namespace mfns::host
