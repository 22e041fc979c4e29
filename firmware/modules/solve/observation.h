// Observation types shared by identification and the pose solver (issue 4, items 5 and 6).
//
// The navigation loop converts the blob detector's output (firmware/modules/detect) into
// BlobObs, one list per frame set with every camera's blobs; identification turns blobs into
// Matches (blob -> beacon); the solver turns Matches into a pose. Plain data, no heap.
#pragma once

#include <Eigen/Core>

#include "common/limits.h"
#include "common/rig/beacon_set.h"

namespace mfns::fw {

// One blob seen by one camera of the rig. At most limits::kMaxBlobsPerFrame per camera.
struct BlobObs {
  int camera = -1;                                 // index into Rig::cameras
  Eigen::Vector2d uv_px = Eigen::Vector2d::Zero();  // distorted image centroid, px
  Eigen::Vector2d x_n = Eigen::Vector2d::Zero();    // undistorted normalised (X/Z, Y/Z)
  float flux = 0.0F;                                // background-subtracted sum, DN (ranking only)
};

// An identified observation: blob `blob` (index into the frame set's BlobObs list), seen by
// camera `camera` (== that blob's camera), is the image of beacon `beacon` (index into
// Rig::beacons_w). At most limits::kMaxMatches per frame set.
struct Match {
  int blob = -1;
  int beacon = -1;
  int camera = -1;
};

}  // namespace mfns::fw
