#include "host/sim/render/visibility.h"

namespace mfns::host {

ProjectedPoint ProjectVisible(const CameraIntrinsics& cam, const Eigen::Vector3d& p_k, double margin_px) {
  ProjectedPoint out;
  Eigen::Vector2d uv;
  out.status = Project(cam, p_k, &uv);
  if (out.status != ProjectStatus::kOk) return out;
  out.uv_px = uv;
  if (!InImage(cam, uv, margin_px)) return out;
  // Fold test: the ray back from the pixel must be the point's own ray (1e-6 normalised is
  // ~2e-3 px at the paper's focal length; a fold lands far away).
  Eigen::Vector2d x_n;
  if (Unproject(cam, uv, &x_n) != UnprojectStatus::kOk) return out;
  const Eigen::Vector2d x_true(p_k.x() / p_k.z(), p_k.y() / p_k.z());
  out.visible = (x_n - x_true).norm() <= 1e-6 * (1.0 + x_true.norm());
  return out;
}

Eigen::Vector3d CameraCentreWorld(const RigCamera& cam, const BodyPose& pose) {
  return pose.r_w_wb + pose.C_w_b * cam.r_b_bk;
}

BeaconSight SightBeacon(const Rig& rig, const BodyPose& pose, int camera, int beacon, double margin_px) {
  const RigCamera& cam = rig.cameras[static_cast<std::size_t>(camera)];
  BeaconSight out;
  out.p_k = WorldToCamera(cam, pose, rig.beacons_w[static_cast<std::size_t>(beacon)]);
  out.faces = BeaconFaces(rig, beacon, CameraCentreWorld(cam, pose));
  out.projection = ProjectVisible(cam.intrinsics, out.p_k, margin_px);
  out.visible = out.faces && out.projection.visible;
  return out;
}

}  // namespace mfns::host
