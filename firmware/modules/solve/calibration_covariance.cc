#include "firmware/modules/solve/calibration_covariance.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <cmath>

#include "common/rotation/rotation.h"

namespace mfns::fw {

namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

constexpr int kExtrinsicParams = 6;  // C_k_b's phi, theta, psi (rad), r_b_bk (m)
constexpr int kParamsPerCamera = kExtrinsicParams + kNumCameraParams;
static_assert(kNumCameraParams == 10, "RigCameraSigma holds 5 intrinsics and 5 distortion terms");

// Camera `base` with parameter p (0..15: Euler angles, position, then CameraParam order) moved
// by h.
RigCamera Perturbed(const RigCamera& base, int p, double h) {
  RigCamera cam = base;
  if (p < 3) {
    EulerAngles e = MatrixToEuler(base.C_k_b);
    (p == 0 ? e.phi : p == 1 ? e.theta : e.psi) += h;
    cam.C_k_b = EulerToMatrix(e);
  } else if (p < kExtrinsicParams) {
    cam.r_b_bk[p - 3] += h;
  } else {
    CameraParamVector v = base.intrinsics.ToVector();
    v[p - kExtrinsicParams] += h;
    cam.intrinsics.SetFromVector(v);
  }
  return cam;
}

double SigmaOf(const RigCameraSigma& s, int p) {
  if (p < 3) return s.euler[p];
  if (p < kExtrinsicParams) return s.r_b_bk[p - 3];
  const int q = p - kExtrinsicParams;
  return q < 5 ? s.intrinsics[static_cast<std::size_t>(q)] : s.distortion[static_cast<std::size_t>(q - 5)];
}

// The difference step of parameter p: small against its scale, large against rounding.
double StepOf(const RigCamera& cam, int p) {
  if (p < kExtrinsicParams) return 1e-6;  // rad, m
  return 1e-6 * std::max(1.0, std::abs(cam.intrinsics.ToVector()[p - kExtrinsicParams]));
}

bool ValidMatch(const Rig& rig, const BlobObs* blobs, int num_blobs, const Match& m) {
  return m.blob >= 0 && m.blob < num_blobs && m.camera >= 0 && m.camera < rig.num_cameras && m.beacon >= 0 &&
         m.beacon < rig.num_beacons && blobs[m.blob].camera == m.camera;
}

}  // namespace

bool CalibrationCovariance(const Rig& rig, const BlobObs* blobs, int num_blobs, const Match* matches, int num_matches,
                           const BodyPose& pose, const SolveOptions& options, Matrix6d* cov) {
  cov->setZero();
  if (!rig.has_sigma || num_matches < 3 || num_matches > limits::kMaxMatches || matches == nullptr || blobs == nullptr)
    return false;
  std::array<double, limits::kMaxMatches> w{};
  w.fill(1.0);
  BeaconWeights(rig, matches, num_matches, options, &w);
  // J^T W J and the 6x2 rows J^T W of every observation.
  std::array<Eigen::Matrix<double, 6, 2>, limits::kMaxMatches> jtw;
  std::array<Eigen::Vector2d, limits::kMaxMatches> uv0;  // the images at the pose, for the differences
  Matrix6d info = Matrix6d::Zero();
  for (int i = 0; i < num_matches; ++i) {
    const Match& m = matches[i];
    if (!ValidMatch(rig, blobs, num_blobs, m)) return false;
    Eigen::Vector2d uv;
    Eigen::Matrix<double, 2, 6> J;
    const auto k = static_cast<std::size_t>(m.camera);
    if (ProjectBeacon(rig.cameras[k], pose, rig.beacons_w[static_cast<std::size_t>(m.beacon)], &uv, &J) !=
        ProjectStatus::kOk)
      return false;
    const auto si = static_cast<std::size_t>(i);
    uv0[si] = uv;
    jtw[si] = J.transpose() * w[si];
    info += jtw[si] * J;
  }
  const Eigen::LDLT<Matrix6d> ldlt(info);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 1e-12 * ldlt.vectorD().maxCoeff())) return false;
  for (int k = 0; k < rig.num_cameras; ++k) {
    const auto sk = static_cast<std::size_t>(k);
    for (int p = 0; p < kParamsPerCamera; ++p) {
      const double s = SigmaOf(rig.sigma[sk], p);
      if (!(s > 0.0)) continue;
      // Forward differences: a relative error of ~1e-6 in a 1-sigma, at half the projections.
      const double h = StepOf(rig.cameras[sk], p);
      const RigCamera moved = Perturbed(rig.cameras[sk], p, h);
      Vector6d g = Vector6d::Zero();  // J^T W d uv / d c over camera k's observations
      for (int i = 0; i < num_matches; ++i) {
        if (matches[i].camera != k) continue;
        const auto si = static_cast<std::size_t>(i);
        Eigen::Vector2d a;
        if (ProjectBeacon(moved, pose, rig.beacons_w[static_cast<std::size_t>(matches[i].beacon)], &a) != ProjectStatus::kOk) {
          cov->setZero();  // the contract: false leaves zero, not a partial sum
          return false;
        }
        g += jtw[si] * ((a - uv0[si]) / h);
      }
      const Vector6d d_pose = ldlt.solve(g);  // the sign is immaterial to the covariance
      *cov += (s * s) * d_pose * d_pose.transpose();
    }
  }
  if (cov->allFinite()) return true;
  cov->setZero();
  return false;
}

}  // namespace mfns::fw
