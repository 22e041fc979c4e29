#include "host/sim/crb/pose_bound.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <cmath>

#include "common/rotation/rotation.h"
#include "host/sim/render/visibility.h"

namespace mfns::host {
namespace {

Eigen::Vector3d EulerOfCbw(const BodyPose& pose) {
  const EulerAngles e = MatrixToEuler(pose.C_w_b.transpose());
  return {e.phi, e.theta, e.psi};
}

}  // namespace

std::vector<VisibleBeacon> VisibleBeacons(const Rig& rig, const BodyPose& pose, double margin_px,
                                          const std::vector<int>& occluded) {
  std::vector<VisibleBeacon> out;
  for (int k = 0; k < rig.num_cameras; ++k) {
    for (int i = 0; i < rig.num_beacons; ++i) {
      bool hidden = false;
      for (int o : occluded) hidden = hidden || o == i;
      if (hidden) continue;
      const BeaconSight sight = SightBeacon(rig, pose, k, i, margin_px);
      if (sight.visible) out.push_back({k, i, sight.projection.uv_px});
    }
  }
  return out;
}

Eigen::Matrix3d EulerJacobian(const BodyPose& pose) {
  constexpr double h = 1e-6;
  Eigen::Matrix3d J;
  for (int i = 0; i < 3; ++i) {
    PoseDelta d = PoseDelta::Zero();
    d[3 + i] = h;
    const Eigen::Vector3d plus = EulerOfCbw(Retract(pose, d));
    d[3 + i] = -h;
    const Eigen::Vector3d minus = EulerOfCbw(Retract(pose, d));
    for (int r = 0; r < 3; ++r) J(r, i) = WrapPi(plus[r] - minus[r]) / (2.0 * h);
  }
  return J;
}

PoseBound PoseCramerRao(const Rig& rig, const BodyPose& pose, const std::vector<VisibleBeacon>& seen,
                        double sigma_px) {
  PoseBound b;
  Eigen::Matrix<double, 6, 6> info = Eigen::Matrix<double, 6, 6>::Zero();
  for (const VisibleBeacon& v : seen) {
    Eigen::Vector2d uv;
    Eigen::Matrix<double, 2, 6> J;
    if (ProjectBeacon(rig.cameras[static_cast<std::size_t>(v.camera)], pose,
                      rig.beacons_w[static_cast<std::size_t>(v.beacon)], &uv, &J) != ProjectStatus::kOk)
      continue;
    info += J.transpose() * J / (sigma_px * sigma_px);
    ++b.num_beacons;
    ++b.per_camera[static_cast<std::size_t>(v.camera)];
  }
  // Singular (fewer than 3 beacons, or a degenerate layout): no finite bound.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(info);
  const double max_ev = eig.eigenvalues().maxCoeff();
  if (b.num_beacons < 3 || !(max_ev > 0) || eig.eigenvalues().minCoeff() < 1e-12 * max_ev) return b;
  b.covariance = info.ldlt().solve(Eigen::Matrix<double, 6, 6>::Identity());
  b.covariance = 0.5 * (b.covariance + b.covariance.transpose());
  b.sigma_position = b.covariance.diagonal().head<3>().cwiseSqrt();
  const Eigen::Matrix3d Je = EulerJacobian(pose);
  b.sigma_euler = (Je * b.covariance.bottomRightCorner<3, 3>() * Je.transpose()).diagonal().cwiseSqrt();
  b.valid = true;
  return b;
}

}  // namespace mfns::host
