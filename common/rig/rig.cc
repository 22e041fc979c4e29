#include "common/rig/rig.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "common/rotation/rotation.h"

namespace mfns {
namespace {

// A fixed char array holds a NUL-terminated, non-empty, printable ASCII string.
template <std::size_t N>
bool IsGoodName(const std::array<char, N>& s) {
  std::size_t len = 0;
  while (len < N && s[len] != '\0') {
    if (s[len] < 0x21 || s[len] > 0x7e) return false;
    ++len;
  }
  return len > 0 && len < N;
}

bool AllFinite(const std::array<double, 5>& a) {
  for (double v : a)
    if (!std::isfinite(v)) return false;
  return true;
}

bool AllNonNegative(const std::array<double, 5>& a) {
  for (double v : a)
    if (v < 0.0) return false;
  return true;
}

RigStatus ValidateCamera(const RigCamera& c) {
  if (!IsGoodName(c.name)) return RigStatus::kBadCameraName;
  const CameraIntrinsics& k = c.intrinsics;
  if (!AllFinite(k.kc) || !std::isfinite(k.alpha_x) || !std::isfinite(k.alpha_y) ||
      !std::isfinite(k.skew) || !std::isfinite(k.u0) || !std::isfinite(k.v0) ||
      !c.C_k_b.allFinite() || !c.r_b_bk.allFinite())
    return RigStatus::kNonFinite;
  if (k.width <= 0 || k.height <= 0 || k.width > limits::kMaxImageWidth ||
      k.height > limits::kMaxImageHeight)
    return RigStatus::kBadImageSize;
  if (!(k.alpha_x >= limits::kMinFocalPx) || !(k.alpha_y >= limits::kMinFocalPx) || k.alpha_x > limits::kMaxFocalPx ||
      k.alpha_y > limits::kMaxFocalPx || std::abs(k.skew) > k.alpha_x || k.u0 < -0.5 || k.u0 > k.width - 0.5 ||
      k.v0 < -0.5 || k.v0 > k.height - 0.5)
    return RigStatus::kBadIntrinsics;
  for (double v : k.kc)
    if (std::abs(v) > limits::kMaxDistortion) return RigStatus::kBadDistortion;
  if (!IsRotation(c.C_k_b, 1e-6)) return RigStatus::kNotARotation;
  if (c.r_b_bk.cwiseAbs().maxCoeff() > limits::kMaxCameraOffsetM) return RigStatus::kBadCameraOffset;
  return RigStatus::kOk;
}

RigStatus ValidateSigma(const RigCameraSigma& s) {
  if (!AllFinite(s.intrinsics) || !AllFinite(s.distortion) || !s.euler.allFinite() ||
      !s.r_b_bk.allFinite())
    return RigStatus::kNonFinite;
  if (!AllNonNegative(s.intrinsics) || !AllNonNegative(s.distortion) || (s.euler.array() < 0).any() ||
      (s.r_b_bk.array() < 0).any())
    return RigStatus::kBadSigma;
  return RigStatus::kOk;
}

}  // namespace

const char* ToString(RigStatus s) {
  switch (s) {
    case RigStatus::kOk: return "ok";
    case RigStatus::kBadRigId: return "rig id empty, too long or not printable";
    case RigStatus::kNoCameras: return "no cameras";
    case RigStatus::kTooManyCameras: return "more cameras than limits::kMaxCameras";
    case RigStatus::kTooManyBeacons: return "more beacons than limits::kMaxBeacons";
    case RigStatus::kBadCameraName: return "camera name empty, too long, not printable or repeated";
    case RigStatus::kBadImageSize: return "image size outside 1..limits::kMaxImageWidth/Height";
    case RigStatus::kBadIntrinsics:
      return "focal length outside 1..1e6 px, |skew| above alpha_x or principal point outside the image";
    case RigStatus::kNotARotation: return "C_k_b is not a rotation matrix";
    case RigStatus::kNonFinite: return "NaN or infinite value";
    case RigStatus::kBadSigma: return "negative sigma, or a beacon sigma above 1000 mm";
    case RigStatus::kBadFacing: return "beacon normal not a unit vector or beam half-angle outside (0, 180] deg";
    case RigStatus::kBadDistortion: return "distortion coefficient outside -1000..1000";
    case RigStatus::kBadCameraOffset: return "camera position r_b_bk outside +-10000 mm of the body origin";
    case RigStatus::kBadBeaconPosition: return "beacon position outside +-1e6 mm (1 km) of the world origin";
    case RigStatus::kDuplicateBeacon: return "two beacons at the same position (closer than 1 mm)";
  }
  return "unknown rig status";
}

int SameBeaconAs(const Rig& rig, int m) {
  const Eigen::Vector3d& p = rig.beacons_w[static_cast<std::size_t>(m)];
  for (int j = 0; j < m; ++j)
    if ((rig.beacons_w[static_cast<std::size_t>(j)] - p).norm() < limits::kMinBeaconSeparationM) return j;
  return -1;
}

RigStatus ValidateRig(const Rig& rig, int* camera_index, int* beacon_index) {
  if (camera_index != nullptr) *camera_index = -1;
  if (beacon_index != nullptr) *beacon_index = -1;
  if (!IsGoodName(rig.rig_id)) return RigStatus::kBadRigId;
  if (rig.num_cameras <= 0) return RigStatus::kNoCameras;
  if (rig.num_cameras > limits::kMaxCameras) return RigStatus::kTooManyCameras;
  if (rig.num_beacons < 0 || rig.num_beacons > limits::kMaxBeacons) return RigStatus::kTooManyBeacons;
  for (int i = 0; i < rig.num_cameras; ++i) {
    const auto idx = static_cast<std::size_t>(i);
    RigStatus s = ValidateCamera(rig.cameras[idx]);
    if (s == RigStatus::kOk && rig.has_sigma) s = ValidateSigma(rig.sigma[idx]);
    for (int j = 0; s == RigStatus::kOk && j < i; ++j) {
      if (std::strcmp(rig.cameras[static_cast<std::size_t>(j)].name.data(),
                      rig.cameras[idx].name.data()) == 0)
        s = RigStatus::kBadCameraName;
    }
    if (s != RigStatus::kOk) {
      if (camera_index != nullptr) *camera_index = i;
      return s;
    }
  }
  for (int i = 0; i < rig.num_beacons; ++i) {
    const Eigen::Vector3d& p = rig.beacons_w[static_cast<std::size_t>(i)];
    RigStatus s = RigStatus::kOk;
    if (!p.allFinite()) {
      s = RigStatus::kNonFinite;
    } else if (p.cwiseAbs().maxCoeff() > limits::kMaxBeaconCoordinateM) {
      s = RigStatus::kBadBeaconPosition;
    } else if (SameBeaconAs(rig, i) >= 0) {  // at most kMaxBeacons^2 / 2 distances
      s = RigStatus::kDuplicateBeacon;
    }
    if (s != RigStatus::kOk) {
      if (beacon_index != nullptr) *beacon_index = i;
      return s;
    }
  }
  double largest = 0.0;
  for (int i = 0; rig.has_beacon_sigmas && i < rig.num_beacons; ++i) {
    const double s = rig.beacon_sigmas[static_cast<std::size_t>(i)];
    const RigStatus bad = !std::isfinite(s) ? RigStatus::kNonFinite
                          : (s < 0.0 || s > limits::kMaxBeaconSigmaM) ? RigStatus::kBadSigma
                                                                      : RigStatus::kOk;
    if (bad != RigStatus::kOk) {
      if (beacon_index != nullptr) *beacon_index = i;
      return bad;
    }
    largest = std::max(largest, s);
  }
  // beacon_sigma is the largest of them (what a reader of the one number must see).
  if (rig.has_beacon_sigmas && rig.beacon_sigma != largest) return RigStatus::kBadSigma;
  if (!std::isfinite(rig.beacon_sigma)) return RigStatus::kNonFinite;
  if (rig.beacon_sigma < 0.0 || rig.beacon_sigma > limits::kMaxBeaconSigmaM) return RigStatus::kBadSigma;
  for (int i = 0; rig.has_facing && i < rig.num_beacons; ++i) {
    const auto idx = static_cast<std::size_t>(i);
    const Eigen::Vector3d& n = rig.beacon_normal_w[idx];
    const double half = rig.beacon_half_angle[idx], tol = rig.beacon_normal_tolerance[idx];
    RigStatus s = RigStatus::kOk;
    if (!n.allFinite() || !std::isfinite(half) || !std::isfinite(tol)) {
      s = RigStatus::kNonFinite;
    } else if (std::abs(n.norm() - 1.0) > 1e-6 || !(half > 0.0) || half > kPi || !(tol >= 0.0) || tol > kPi / 2) {
      s = RigStatus::kBadFacing;
    }
    if (s != RigStatus::kOk) {
      if (beacon_index != nullptr) *beacon_index = i;
      return s;
    }
  }
  return RigStatus::kOk;
}

double FacingCosine(const Rig& rig, int m, double margin_rad) {
  if (!rig.has_facing) return -2.0;
  // An inferred normal's tolerance narrows "surely seen" only (rig.h).
  const double tol = rig.beacon_normal_tolerance[static_cast<std::size_t>(m)];
  const double half = rig.beacon_half_angle[static_cast<std::size_t>(m)] + margin_rad - (margin_rad < 0.0 ? tol : 0.0);
  if (half >= kPi) return -2.0;
  if (half <= 0.0) return 2.0;
  return std::cos(half);
}

bool BeaconFacesCos(const Rig& rig, int m, const Eigen::Vector3d& p_w, double facing_cosine) {
  if (facing_cosine <= -1.0) return true;
  if (facing_cosine > 1.0) return false;
  const auto idx = static_cast<std::size_t>(m);
  const Eigen::Vector3d u = p_w - rig.beacons_w[idx];
  const double len = u.norm();
  if (!(len > 0.0)) return true;
  return u.dot(rig.beacon_normal_w[idx]) >= facing_cosine * len;
}

bool BeaconFaces(const Rig& rig, int m, const Eigen::Vector3d& p_w, double margin_rad) {
  if (!rig.has_facing) return true;
  return BeaconFacesCos(rig, m, p_w, FacingCosine(rig, m, margin_rad));
}

BodyPose Retract(const BodyPose& pose, const PoseDelta& delta) {
  BodyPose out;
  out.r_w_wb = pose.r_w_wb + delta.head<3>();
  out.C_w_b = pose.C_w_b * ExpSO3(delta.tail<3>());
  return out;
}

Eigen::Vector3d WorldToCamera(const RigCamera& cam, const BodyPose& pose, const Eigen::Vector3d& P_w) {
  // C_b_w * P_w + r_b_bw with r_b_bw = -C_b_w * r_w_wb.
  const Eigen::Vector3d p_b = pose.C_w_b.transpose() * (P_w - pose.r_w_wb);
  return cam.C_k_b * (p_b - cam.r_b_bk);
}

ProjectStatus ProjectBeacon(const RigCamera& cam, const BodyPose& pose, const Eigen::Vector3d& P_w,
                            Eigen::Vector2d* uv_px, Eigen::Matrix<double, 2, 6>* J_uv_pose,
                            Eigen::Matrix<double, 2, 3>* J_uv_Pw) {
  const Eigen::Matrix3d C_b_w = pose.C_w_b.transpose();
  const Eigen::Vector3d p_b = C_b_w * (P_w - pose.r_w_wb);
  const Eigen::Vector3d p_k = cam.C_k_b * (p_b - cam.r_b_bk);
  Eigen::Matrix<double, 2, 3> J_uv_pk;
  const ProjectStatus s = Project(cam.intrinsics, p_k, uv_px, &J_uv_pk);
  if (s != ProjectStatus::kOk) return s;
  const Eigen::Matrix<double, 2, 3> J_uv_pb = J_uv_pk * cam.C_k_b;
  if (J_uv_pose != nullptr) {
    // dp_b = -C_b_w dr_w + [p_b]x dtheta_b   (C_b_w <- Exp(-dtheta) C_b_w).
    J_uv_pose->leftCols<3>() = -J_uv_pb * C_b_w;
    J_uv_pose->rightCols<3>() = J_uv_pb * Skew(p_b);
  }
  if (J_uv_Pw != nullptr) *J_uv_Pw = J_uv_pb * C_b_w;
  return ProjectStatus::kOk;
}

}  // namespace mfns
