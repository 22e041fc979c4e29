// Whether a pose's beacon identities are decided by the pose itself: each matched beacon,
// predicted from the pose's other beacons, has no other free blob of its camera within the
// prediction's error.
//
// Why: a pose on four beacons of one narrow camera and one of another has a weak direction (a
// rotation and a translation that move the first camera's images by a fraction of a pixel); the
// other camera's beacon can slide 100 px along it. Any blob there fits that beacon, and a
// spurious one gives a pose that explains every blob with residuals of 0.07 px, none missing.
// Seen: `mfns-sim navmatrix --layout random`, box 128 seed 4, frame set 48, a lost-in-space fix
// 69 mm / 0.95 deg off (9 of its 1-sigma) on a reflection 115 px from the beacon's own blob.
// The a-contrario confirmation counts such a match as unlikely by chance, as if the beacon's
// place were known to the match gate; the leave-one-out prediction says how well it is known.
#pragma once

#include <Eigen/Core>

#include "common/rig/rig.h"
#include "firmware/modules/identify/match.h"
#include "firmware/modules/solve/observation.h"

namespace mfns::fw {

// A matched beacon and the other blob that fits it as well (IdentitiesDecisive's answer).
struct IdentityRival {
  int beacon = -1;
  int camera = -1;
  int blob = -1;        // the beacon's matched blob
  int rival_blob = -1;  // the other free blob within the gate
  double d2 = 0.0;      // its squared Mahalanobis distance
};

// For each match (blob -> beacon of camera k) of `matches` at `pose`, with the pose's covariance
// (the solve's, PoseDelta parametrisation, centroid noise sigma_px only): the pose's information
// less the beacon's own (J^T J / sigma_px^2) gives the pose the other beacons would give (one
// Gauss-Newton step) and its covariance, so the beacon's leave-one-out prediction u and
// S = J Sigma_-m J^T + image_sigma_px^2 I (the blob's noise, with the map's error as image
// noise). A blob of camera k matched to no other beacon, other than the beacon's own, with
// (b - u)^T S^-1 (b - u) <= gate_chi2 is a rival: it fits the beacon as the other beacons see it
// (for noise-free blobs, exactly the chi-square of the solve with it in the beacon's place).
// When the other beacons do not fix the pose (information not positive definite), every free
// blob of the camera is one. Returns true when no beacon has a rival; else false and *rival
// (optional) names the first found. Bad input (non-finite covariance, blobs out of range):
// false. No heap.
bool IdentitiesDecisive(const Rig& rig, const BodyPose& pose, const Eigen::Matrix<double, 6, 6>& covariance,
                        double sigma_px, double image_sigma_px, const BlobObs* blobs, int num_blobs,
                        const Match* matches, int num_matches, double gate_chi2, IdentityRival* rival = nullptr);

}  // namespace mfns::fw
