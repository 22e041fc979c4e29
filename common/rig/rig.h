// Rig model: cameras rigidly mounted on the body, beacons in the world, and the observation of
// paper eq. 2:  p_k = C_k_b * (C_b_w * P_w + r_b_bw - r_b_bk),  then the camera model.
//
// Units: metres and radians inside the program (file formats carry _mm / _deg). Frames:
// w world, b body, k camera (DESIGN.md). Fixed-size storage, no heap: usable on the flyer.
#pragma once

#include <Eigen/Core>
#include <array>

#include "common/camera/camera.h"
#include "common/limits.h"

namespace mfns {

struct RigCamera {
  std::array<char, limits::kMaxCameraNameChars + 1> name{};  // NUL-terminated, e.g. "x"
  CameraIntrinsics intrinsics;
  Eigen::Matrix3d C_k_b = Eigen::Matrix3d::Identity();  // body -> camera k
  Eigen::Vector3d r_b_bk = Eigen::Vector3d::Zero();     // body origin -> camera centre, in b, m
};

// Optional 1-sigma of a camera's calibration, in the rig file's quantities (SI units here).
struct RigCameraSigma {
  std::array<double, 5> intrinsics{};  // alpha_x, alpha_y, skew, u0, v0 (px)
  std::array<double, 5> distortion{};  // kc1..kc5
  Eigen::Vector3d euler = Eigen::Vector3d::Zero();   // phi, theta, psi of C_k_b (rad)
  Eigen::Vector3d r_b_bk = Eigen::Vector3d::Zero();  // m
};

struct Rig {
  std::array<char, limits::kMaxRigIdChars + 1> rig_id{};  // NUL-terminated compatibility string
  int num_cameras = 0;
  std::array<RigCamera, limits::kMaxCameras> cameras{};
  bool has_sigma = false;
  std::array<RigCameraSigma, limits::kMaxCameras> sigma{};
  int num_beacons = 0;
  std::array<Eigen::Vector3d, limits::kMaxBeacons> beacons_w{};  // world frame, m
  double beacon_sigma = 0.0;  // 1-sigma of each beacon coordinate (m); 0 = unknown
  // Optional per-beacon 1-sigma (m per coordinate; e.g. mfns-calib survey's, where each beacon
  // is known as well as it was seen). When present beacon_sigma is their largest: every reader
  // of the one number (the navigator's gates and covariance today) stays on the safe side.
  bool has_beacon_sigmas = false;
  std::array<double, limits::kMaxBeacons> beacon_sigmas{};
  // Optional facing of every beacon (all or none): the unit normal of its emitting side
  // (world frame) and its beam half-angle (rad, in (0, pi]). Beacon m is visible from a point
  // p_w only when the angle between p_w - P_m and its normal is at most the half-angle (an LED
  // on a wall is not seen from behind it). Without facing data every direction is allowed.
  // A half-angle of pi (180 deg) means the beam is unknown: the beacon may be seen from
  // anywhere, but its absence refutes nothing (firmware/modules/identify/match.h); a map
  // without facing gets its facing inferred by the navigator (common/rig/infer_facing.h).
  bool has_facing = false;
  std::array<Eigen::Vector3d, limits::kMaxBeacons> beacon_normal_w{};
  std::array<double, limits::kMaxBeacons> beacon_half_angle{};
  // How far each normal may be off (rad, in [0, pi/2]): 0 for surveyed facing; InferFacing sets
  // the angle of the map's hull normal cone at the beacon. FacingCosine narrows a beam by it for
  // "surely seen" (margin < 0), where a wrong normal would make a missing beacon refute the true
  // pose; "may be seen" is not widened (a beacon seen outside it only goes unmatched, and wider
  // beams multiplied lost-in-space's hypotheses: measured, first fixes 2-3x later). Not in rig
  // files or blobs.
  std::array<double, limits::kMaxBeacons> beacon_normal_tolerance{};
};

// Whether beacon m (0 <= m < rig.num_beacons) can be seen from p_w by its facing (always true
// without facing data). margin_rad widens the beam (> 0, for points known only roughly) or
// narrows it (< 0, where only a beacon well inside its beam is surely detected).
bool BeaconFaces(const Rig& rig, int m, const Eigen::Vector3d& p_w, double margin_rad = 0.0);
// The same test split for loops over many points: FacingCosine (the cosine of beacon m's beam
// half-angle plus margin_rad; -2 for a beam that covers every direction, 2 for none) once,
// then BeaconFacesCos per point.
double FacingCosine(const Rig& rig, int m, double margin_rad);
bool BeaconFacesCos(const Rig& rig, int m, const Eigen::Vector3d& p_w, double facing_cosine);

// Why a rig is not usable; kOk when it is.
enum class RigStatus : unsigned char {
  kOk = 0,
  kBadRigId,          // empty, unterminated or non-printable
  kNoCameras,
  kTooManyCameras,
  kTooManyBeacons,
  kBadCameraName,     // empty, unterminated, non-printable or duplicated
  kBadImageSize,      // <= 0 or above limits::kMaxImageWidth/Height
  kBadIntrinsics,     // alpha <= 0 or principal point outside the image
  kNotARotation,      // C_k_b not orthonormal with det +1 (1e-6)
  kNonFinite,         // NaN or Inf anywhere
  kBadSigma,          // negative sigma, or beacon_sigma not the largest of beacon_sigmas
  kBadFacing,         // beacon normal not a unit vector (1e-6) or half-angle outside (0, pi]
  // Physically sensible ranges (common/limits.h):
  kBadDistortion,      // |kc_i| above limits::kMaxDistortion
  kBadCameraOffset,    // |r_b_bk| component above limits::kMaxCameraOffsetM
  kBadBeaconPosition,  // |beacon coordinate| above limits::kMaxBeaconCoordinateM
  kDuplicateBeacon,    // two beacons closer than limits::kMinBeaconSeparationM
};
const char* ToString(RigStatus s);

// Checks every field; on failure *camera_index (optional) names the offending camera or -1,
// and *beacon_index (optional) the offending beacon or -1 (for kDuplicateBeacon the later of
// the two; SameBeaconAs gives the earlier). Besides finiteness, every number must lie in its
// physically sensible range: focal lengths limits::kMinFocalPx..kMaxFocalPx, |skew| <= alpha_x,
// the principal point inside the image, |kc_i| <= kMaxDistortion, |r_b_bk| components <=
// kMaxCameraOffsetM, beacon coordinates within +-kMaxBeaconCoordinateM and no two beacons
// closer than kMinBeaconSeparationM, the beacon sigma <= kMaxBeaconSigmaM.
RigStatus ValidateRig(const Rig& rig, int* camera_index = nullptr, int* beacon_index = nullptr);

// The first beacon before m closer to beacon m than limits::kMinBeaconSeparationM, or -1.
int SameBeaconAs(const Rig& rig, int m);

// Body pose: attitude C_w_b (body -> world) and position r_w_wb (body origin in world, m).
// Eq. 2 uses C_b_w = C_w_b^T and r_b_bw = -C_b_w * r_w_wb.
struct BodyPose {
  Eigen::Matrix3d C_w_b = Eigen::Matrix3d::Identity();
  Eigen::Vector3d r_w_wb = Eigen::Vector3d::Zero();
};

// Pose perturbation used by every pose Jacobian and covariance in MFNS:
// delta = [dr_w (3, m, world frame); dtheta_b (3, rad, body frame)],
// r_w_wb <- r_w_wb + dr_w,  C_w_b <- C_w_b * Exp(dtheta_b).
using PoseDelta = Eigen::Matrix<double, 6, 1>;
BodyPose Retract(const BodyPose& pose, const PoseDelta& delta);

// Eq. 2: the beacon P_w in camera k's frame (m).
Eigen::Vector3d WorldToCamera(const RigCamera& cam, const BodyPose& pose, const Eigen::Vector3d& P_w);

// Image of beacon P_w in camera k (eq. 2 + camera model), with optional Jacobians with respect
// to the pose perturbation above and to the beacon position. Outputs are untouched unless kOk.
ProjectStatus ProjectBeacon(const RigCamera& cam, const BodyPose& pose, const Eigen::Vector3d& P_w,
                            Eigen::Vector2d* uv_px,
                            Eigen::Matrix<double, 2, 6>* J_uv_pose = nullptr,
                            Eigen::Matrix<double, 2, 3>* J_uv_Pw = nullptr);

}  // namespace mfns
