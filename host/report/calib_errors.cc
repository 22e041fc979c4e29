#include "host/report/calib_errors.h"

#include <cmath>
#include <cstring>

#include "common/rotation/rotation.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

const RigCamera* FindCamera(const Rig& rig, const char* name) {
  for (int i = 0; i < rig.num_cameras; ++i)
    if (std::strcmp(rig.cameras[static_cast<std::size_t>(i)].name.data(), name) == 0)
      return &rig.cameras[static_cast<std::size_t>(i)];
  return nullptr;
}

}  // namespace

std::vector<CameraCalibError> CompareCalibration(const Rig& estimate, const Rig& truth) {
  std::vector<CameraCalibError> out;
  for (int i = 0; i < estimate.num_cameras; ++i) {
    const RigCamera& est = estimate.cameras[static_cast<std::size_t>(i)];
    const RigCamera* tru = FindCamera(truth, est.name.data());
    if (tru == nullptr) continue;
    CameraCalibError e;
    e.name = est.name.data();
    const EulerAngles a = MatrixToEuler(est.C_k_b), b = MatrixToEuler(tru->C_k_b);
    e.euler_error_deg = Eigen::Vector3d(Wrap180Deg(RadToDeg(a.phi - b.phi)), Wrap180Deg(RadToDeg(a.theta - b.theta)),
                                        Wrap180Deg(RadToDeg(a.psi - b.psi)));
    const Eigen::Vector3d w = LogSO3(tru->C_k_b.transpose() * est.C_k_b);
    e.rotation_error_b_deg = w * RadToDeg(1.0);
    e.rotation_deg = e.rotation_error_b_deg.norm();
    e.position_error_mm = (est.r_b_bk - tru->r_b_bk) * 1e3;
    e.position_mm = e.position_error_mm.norm();
    e.has_sigma = estimate.has_sigma;
    if (estimate.has_sigma) {
      const RigCameraSigma& s = estimate.sigma[static_cast<std::size_t>(i)];
      e.euler_sigma_deg = s.euler * RadToDeg(1.0);
      e.position_sigma_mm = s.r_b_bk * 1e3;
    }
    out.push_back(e);
  }
  if (out.empty()) throw UserError("no camera of the calibrated rig is in the truth rig");
  return out;
}

Rig MergeRig(const Rig& cameras, const Rig& beacons) {
  Rig r = cameras;
  r.num_beacons = beacons.num_beacons;
  r.beacons_w = beacons.beacons_w;
  r.beacon_sigma = beacons.beacon_sigma;
  r.has_facing = beacons.has_facing;
  r.beacon_normal_w = beacons.beacon_normal_w;
  r.beacon_half_angle = beacons.beacon_half_angle;
  return r;
}

}  // namespace mfns::host
