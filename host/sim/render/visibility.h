// Truth projection shared by the renderers and the blob-level simulation: where a point in a
// camera frame images, and whether it is really seen. SightBeacon is the ONE visibility decision
// of the simulator: the LED renderer, blobs.csv, the blob-level simulation (host/sim/observe),
// the Cramér-Rao bound and every visibility count call it.
#pragma once

#include <Eigen/Core>

#include "common/camera/camera.h"
#include "common/rig/rig.h"

namespace mfns::host {

struct ProjectedPoint {
  ProjectStatus status = ProjectStatus::kNonFinite;  // of mfns::Project
  Eigen::Vector2d uv_px = Eigen::Vector2d::Constant(-1.0);  // valid when status is kOk
  // In front of the camera (Project ok), inside the image shrunk by the margin, and not a
  // ghost of the distortion polynomial: unprojecting uv_px gives back the point's ray (a
  // point far outside the field of view can fold back into the image under strong
  // distortion; it is not visible).
  bool visible = false;
};

// p_k: the point in camera frame k (any length unit). margin_px as in mfns::InImage.
ProjectedPoint ProjectVisible(const CameraIntrinsics& cam, const Eigen::Vector3d& p_k, double margin_px);

// Camera k's projection centre in the world frame at body pose `pose` (m).
Eigen::Vector3d CameraCentreWorld(const RigCamera& cam, const BodyPose& pose);

// How camera `camera` of the rig sees beacon `beacon` at body pose `pose`.
struct BeaconSight {
  Eigen::Vector3d p_k = Eigen::Vector3d::Zero();  // the beacon in camera frame k (m), eq. 2
  bool faces = true;           // the camera centre is inside the beacon's beam (mfns::BeaconFaces)
  ProjectedPoint projection;   // ProjectVisible(p_k, margin_px)
  // The beacon's spot is in the image: faces && projection.visible. Only these are blobs.
  bool visible = false;
  // The renderer draws the spot (possibly straddling the border) when it faces the camera and
  // projects, visible or not.
  bool Drawn() const { return faces && projection.status == ProjectStatus::kOk; }
};

// 0 <= camera < rig.num_cameras, 0 <= beacon < rig.num_beacons. The beam test uses the rig's
// facing data (always passes without it), so the truth rig decides what is seen.
BeaconSight SightBeacon(const Rig& rig, const BodyPose& pose, int camera, int beacon, double margin_px);

}  // namespace mfns::host
