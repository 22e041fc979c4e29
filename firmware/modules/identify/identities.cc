#include "firmware/modules/identify/identities.h"

#include <Eigen/Cholesky>

namespace mfns::fw {

namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

// Whether blob b is matched to some beacon of the list.
bool Matched(const Match* matches, int num_matches, int b) {
  for (int i = 0; i < num_matches; ++i)
    if (matches[i].blob == b) return true;
  return false;
}

}  // namespace

bool IdentitiesDecisive(const Rig& rig, const BodyPose& pose, const Matrix6d& covariance, double sigma_px,
                        double image_sigma_px, const BlobObs* blobs, int num_blobs, const Match* matches,
                        int num_matches, double gate_chi2, IdentityRival* rival) {
  if (!covariance.allFinite() || !(sigma_px > 0.0) || !(image_sigma_px >= sigma_px) || num_blobs < 0 ||
      (num_blobs > 0 && blobs == nullptr) || num_matches < 0 || (num_matches > 0 && matches == nullptr))
    return false;
  const Eigen::LDLT<Matrix6d> cov(covariance);
  if (cov.info() != Eigen::Success || !(cov.vectorD().minCoeff() > 0.0)) return false;
  const Matrix6d information = cov.solve(Matrix6d::Identity());
  const double var_px = sigma_px * sigma_px;
  for (int i = 0; i < num_matches; ++i) {
    const Match& m = matches[i];
    if (m.blob < 0 || m.blob >= num_blobs || m.beacon < 0 || m.beacon >= rig.num_beacons || m.camera < 0 ||
        m.camera >= rig.num_cameras)
      return false;
    Eigen::Vector2d uv;
    Eigen::Matrix<double, 2, 6> J;
    if (ProjectBeacon(rig.cameras[static_cast<std::size_t>(m.camera)], pose,
                      rig.beacons_w[static_cast<std::size_t>(m.beacon)], &uv, &J) != ProjectStatus::kOk)
      continue;  // (the solve left it out)
    // The pose from the other beacons: their information alone, and the pose they would give
    // (one Gauss-Newton step from the joint pose, whose gradient without this beacon's residual
    // r is -J^T r / sigma^2): the beacon is predicted at uv + J delta.
    const Eigen::LDLT<Matrix6d> others(information - J.transpose() * J / var_px);
    const bool fixed = others.info() == Eigen::Success && others.vectorD().minCoeff() > 1e-9 * information.trace();
    const Eigen::Vector2d r = blobs[m.blob].uv_px - uv;
    Eigen::Vector2d predicted = uv;
    Eigen::Matrix2d S = image_sigma_px * image_sigma_px * Eigen::Matrix2d::Identity();
    if (fixed) {
      predicted -= J * others.solve(J.transpose() * r) / var_px;
      S += J * others.solve(J.transpose());
    }
    const Eigen::LDLT<Eigen::Matrix2d> S_ldlt(S);
    // Another free blob of the camera that fits the prediction.
    int other = -1;
    double other_d2 = 0.0;
    for (int b = 0; b < num_blobs; ++b) {
      if (blobs[b].camera != m.camera || (b != m.blob && Matched(matches, num_matches, b))) continue;
      const Eigen::Vector2d d = blobs[b].uv_px - predicted;
      const double d2 = fixed ? d.dot(S_ldlt.solve(d)) : 0.0;
      if (d2 > gate_chi2 || b == m.blob) continue;
      other = b;
      other_d2 = d2;
      break;
    }
    if (other < 0) continue;  // only its own blob fits (or none: a beacon the others contradict
                              // has a residual the solve's own tests judge)
    if (rival != nullptr) *rival = IdentityRival{m.beacon, m.camera, m.blob, other, other_d2};
    return false;
  }
  return true;
}

}  // namespace mfns::fw
