// Truth projection shared by the renderers: where a point in a camera frame images, and
// whether it is really seen.
#pragma once

#include <Eigen/Core>

#include "common/camera/camera.h"

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

}  // namespace mfns::host
