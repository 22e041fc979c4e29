// CalibrationCovariance against independent references: the solver itself (a rig whose
// calibration is off by one parameter's 1-sigma moves the solved pose by what the first-order
// propagation says), and a Monte Carlo of calibration errors on two rigs and two maps (the
// published covariance with the calibration's part is honest: mean NEES ~6; without it, far
// too small).
#include "firmware/modules/solve/calibration_covariance.h"

#include <gtest/gtest.h>

#include <random>

#include "common/rig/paper_rig.h"
#include "firmware/modules/solve/solve.h"
#include "firmware/modules/solve/synthetic_scene.h"

namespace mfns::fw {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;
using testing::Observe;

// A calibration's 1-sigma large enough to dominate 0.05 px of centroid noise (a few tenths of
// a pixel at the beacons), with the parameters a calibration fixes (skew, k3) at zero.
void SetSigma(Rig* rig) {
  rig->has_sigma = true;
  for (int k = 0; k < rig->num_cameras; ++k) {
    RigCameraSigma& s = rig->sigma[static_cast<std::size_t>(k)];
    s.euler = Eigen::Vector3d::Constant(DegToRad(0.02));
    s.r_b_bk = Eigen::Vector3d::Constant(0.3e-3);
    s.intrinsics = {0.5, 0.5, 0.0, 0.3, 0.3};
    s.distortion = {1e-3, 1e-3, 1e-5, 1e-5, 0.0};
  }
}

// The paper's three cameras, or four wide-angle ones (f = 760 px, k1 = -0.27; the fourth looks
// the other way from the first).
Rig WithCameras(Rig rig, bool wide4) {
  if (wide4) {
    rig.num_cameras = 4;
    rig.cameras[3] = rig.cameras[0];
    rig.cameras[3].C_k_b = rig.cameras[0].C_k_b * R3(kPi);
    rig.cameras[3].name = {'w', '\0'};
    for (int k = 0; k < 4; ++k) {
      CameraIntrinsics& in = rig.cameras[static_cast<std::size_t>(k)].intrinsics;
      in.alpha_x = in.alpha_y = 760.0;
      in.kc = {-0.27, 0.08, 0.0, 0.0, 0.0};
    }
  }
  SetSigma(&rig);
  return rig;
}

// Camera parameters drawn from (or set by) a sigma: the rig a calibration with that error gives.
Rig Miscalibrated(const Rig& truth, std::mt19937_64* rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Rig rig = truth;
  for (int k = 0; k < truth.num_cameras; ++k) {
    const auto sk = static_cast<std::size_t>(k);
    const RigCameraSigma& s = truth.sigma[sk];
    RigCamera& cam = rig.cameras[sk];
    EulerAngles e = MatrixToEuler(cam.C_k_b);
    e.phi += s.euler[0] * n(*rng);
    e.theta += s.euler[1] * n(*rng);
    e.psi += s.euler[2] * n(*rng);
    cam.C_k_b = EulerToMatrix(e);
    for (int j = 0; j < 3; ++j) cam.r_b_bk[j] += s.r_b_bk[j] * n(*rng);
    CameraParamVector v = cam.intrinsics.ToVector();
    for (int j = 0; j < 5; ++j) v[j] += s.intrinsics[static_cast<std::size_t>(j)] * n(*rng);
    for (int j = 0; j < 5; ++j) v[5 + j] += s.distortion[static_cast<std::size_t>(j)] * n(*rng);
    cam.intrinsics.SetFromVector(v);
  }
  return rig;
}

Vector6d PoseError(const BodyPose& est, const BodyPose& truth) {
  Vector6d e;
  e << est.r_w_wb - truth.r_w_wb, LogSO3(truth.C_w_b.transpose() * est.C_w_b);
  return e;
}

int Matches(const testing::Scene& s, std::array<Match, limits::kMaxMatches>* m) {
  int n = 0;
  for (int i = 0; i < s.num_blobs && n < limits::kMaxMatches; ++i)
    (*m)[static_cast<std::size_t>(n++)] = Match{i, s.truth_beacon[static_cast<std::size_t>(i)], s.blobs[static_cast<std::size_t>(i)].camera};
  return n;
}

SolveOptions Options(double sigma_px) {
  SolveOptions o;
  o.sigma_px = sigma_px;
  o.loss = RobustLoss::kNone;
  o.outlier_threshold_px = 0.0;
  return o;
}

// One parameter at a time, off by its 1-sigma (+ or -): the re-solved pose moves by d, and the
// covariance with only that parameter's sigma is d d^T (first order: within 5 %).
TEST(CalibrationCovariance, OneParameterOffByItsSigmaMovesThePoseAsPredicted) {
  std::mt19937_64 rng(3);
  for (const bool wide4 : {false, true}) {
    const Rig truth = WithCameras(testing::RandomBoxRig(40, &rng), wide4);
    int checked = 0, poses = 0;
    // Three poses with at least six beacons in view (random ones until then: the paper's three
    // narrow cameras see fewer from many places in the box).
    for (int trial = 0; trial < 200 && poses < 3; ++trial) {
      const BodyPose pose = testing::RandomBoxPose(&rng);
      testing::Scene scene;
      Observe(truth, pose, 0.0, &rng, &scene);
      std::array<Match, limits::kMaxMatches> m;
      const int n = Matches(scene, &m);
      if (scene.NumVisibleBeacons() < 6) continue;
      ++poses;
      for (int k = 0; k < truth.num_cameras; ++k) {
        if (scene.per_camera[static_cast<std::size_t>(k)] == 0) continue;
        for (int p = 0; p < 16; ++p) {
          Rig one = truth;  // only parameter p of camera k has a sigma
          one.sigma = {};
          RigCameraSigma& s = one.sigma[static_cast<std::size_t>(k)];
          const RigCameraSigma& full = truth.sigma[static_cast<std::size_t>(k)];
          if (p < 3) s.euler[p] = full.euler[p];
          else if (p < 6) s.r_b_bk[p - 3] = full.r_b_bk[p - 3];
          else if (p < 11) s.intrinsics[static_cast<std::size_t>(p - 6)] = full.intrinsics[static_cast<std::size_t>(p - 6)];
          else s.distortion[static_cast<std::size_t>(p - 11)] = full.distortion[static_cast<std::size_t>(p - 11)];
          if (s.euler.isZero() && s.r_b_bk.isZero() && s.intrinsics == std::array<double, 5>{} &&
              s.distortion == std::array<double, 5>{})
            continue;
          // Off by exactly +1 sigma: a one-parameter "draw" of Miscalibrated.
          Rig believed = one;
          const RigCameraSigma only = s;
          {
            RigCamera& cam = believed.cameras[static_cast<std::size_t>(k)];
            if (p < 3) {
              EulerAngles e = MatrixToEuler(cam.C_k_b);
              (p == 0 ? e.phi : p == 1 ? e.theta : e.psi) += only.euler[p];
              cam.C_k_b = EulerToMatrix(e);
            } else if (p < 6) {
              cam.r_b_bk[p - 3] += only.r_b_bk[p - 3];
            } else {
              CameraParamVector v = cam.intrinsics.ToVector();
              v[p - 6] += p < 11 ? only.intrinsics[static_cast<std::size_t>(p - 6)] : only.distortion[static_cast<std::size_t>(p - 11)];
              cam.intrinsics.SetFromVector(v);
            }
          }
          SolveResult r;
          ASSERT_EQ(SolvePose(believed, scene.blobs.data(), scene.num_blobs, m.data(), n, pose, Options(0.05), &r),
                    SolveStatus::kOk);
          const Vector6d d = PoseError(r.pose, pose);
          Matrix6d cov;
          ASSERT_TRUE(CalibrationCovariance(believed, scene.blobs.data(), scene.num_blobs, m.data(), n, r.pose,
                                            Options(0.05), &cov));
          const Matrix6d expected = d * d.transpose();
          EXPECT_LE((cov - expected).norm(), 0.05 * expected.norm() + 1e-16)
              << "wide4 " << wide4 << " camera " << k << " parameter " << p << ": moved " << d.transpose();
          ++checked;
        }
      }
    }
    EXPECT_EQ(poses, 3) << "wide4 " << wide4;
    EXPECT_GE(checked, 40) << "wide4 " << wide4;
  }
}

// Mean NEES of the published covariance (centroid noise + calibration) over calibration errors
// drawn from the sigma and fresh centroid noise: about 6 (the chi-square's mean); without the
// calibration's part it is several times that.
TEST(CalibrationCovariance, PublishedCovarianceIsHonestOverCalibrationErrors) {
  const int trials = testing::Trials(400, 80);
  struct Case {
    bool wide4;
    bool cylinder;
  } cases[] = {{false, false}, {true, false}, {false, true}, {true, true}};
  for (const Case& c : cases) {
    std::mt19937_64 rng(11U + (c.wide4 ? 2U : 0U) + (c.cylinder ? 1U : 0U));
    const Rig truth = WithCameras(c.cylinder ? testing::RandomCylinderRig(128, true, &rng) : testing::RandomBoxRig(40, &rng),
                                  c.wide4);
    double nees_with = 0.0, nees_without = 0.0;
    int n_ok = 0;
    for (int t = 0; t < trials; ++t) {
      const BodyPose pose = c.cylinder ? testing::RandomCylinderPose(&rng) : testing::RandomBoxPose(&rng);
      testing::Scene scene;
      Observe(truth, pose, 0.05, &rng, &scene);
      if (scene.NumVisibleBeacons() < 4) continue;
      std::array<Match, limits::kMaxMatches> m;
      const int n = Matches(scene, &m);
      const Rig believed = Miscalibrated(truth, &rng);
      SolveResult r;
      if (SolvePose(believed, scene.blobs.data(), scene.num_blobs, m.data(), n, pose, Options(0.05), &r) !=
              SolveStatus::kOk ||
          !r.has_covariance)
        continue;
      Matrix6d cal;
      ASSERT_TRUE(CalibrationCovariance(believed, scene.blobs.data(), scene.num_blobs, m.data(), n, r.pose, Options(0.05), &cal));
      const Vector6d e = PoseError(r.pose, pose);
      nees_with += e.dot((r.covariance + cal).ldlt().solve(e));
      nees_without += e.dot(r.covariance.ldlt().solve(e));
      ++n_ok;
    }
    ASSERT_GE(n_ok, trials / 2);
    nees_with /= n_ok;
    nees_without /= n_ok;
    std::printf("wide4 %d cylinder %d: %d poses, mean NEES %.2f with the calibration's covariance, %.2f without\n",
                c.wide4, c.cylinder, n_ok, nees_with, nees_without);
    EXPECT_GT(nees_with, 4.5);
    EXPECT_LT(nees_with, 7.5);
    EXPECT_GT(nees_without, 3.0 * nees_with);
  }
}

TEST(CalibrationCovariance, NoSigmaOrBadInputGivesFalseAndZero) {
  std::mt19937_64 rng(5);
  Rig rig = WithCameras(testing::RandomBoxRig(40, &rng), false);
  testing::Scene scene;
  BodyPose pose;
  for (int t = 0; t < 100 && scene.NumVisibleBeacons() < 4; ++t) {
    pose = testing::RandomBoxPose(&rng);
    Observe(rig, pose, 0.0, &rng, &scene);
  }
  ASSERT_GE(scene.NumVisibleBeacons(), 4);
  std::array<Match, limits::kMaxMatches> m;
  const int n = Matches(scene, &m);
  Matrix6d cov = Matrix6d::Identity();
  EXPECT_TRUE(CalibrationCovariance(rig, scene.blobs.data(), scene.num_blobs, m.data(), n, pose, Options(0.05), &cov));
  EXPECT_GT(cov.trace(), 0.0);
  rig.has_sigma = false;
  EXPECT_FALSE(CalibrationCovariance(rig, scene.blobs.data(), scene.num_blobs, m.data(), n, pose, Options(0.05), &cov));
  EXPECT_TRUE(cov.isZero());
  rig.has_sigma = true;
  m[0].blob = scene.num_blobs;  // names a blob that is not there
  cov.setIdentity();
  EXPECT_FALSE(CalibrationCovariance(rig, scene.blobs.data(), scene.num_blobs, m.data(), n, pose, Options(0.05), &cov));
  EXPECT_TRUE(cov.isZero());
  m[0].blob = 0;
  m[0].beacon = rig.num_beacons;
  EXPECT_FALSE(CalibrationCovariance(rig, scene.blobs.data(), scene.num_blobs, m.data(), n, pose, Options(0.05), &cov));
  EXPECT_FALSE(CalibrationCovariance(rig, scene.blobs.data(), scene.num_blobs, m.data(), 2, pose, Options(0.05), &cov));
}

}  // namespace
}  // namespace mfns::fw
