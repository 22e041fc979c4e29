#include "firmware/modules/identify/identities.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "common/rig/paper_rig.h"
#include "firmware/modules/solve/solve.h"
#include "firmware/modules/solve/synthetic_scene.h"

namespace mfns::fw {
namespace {

constexpr double kSigmaPx = 0.2;
constexpr double kGate = 13.8;

// A beacon at camera k's image point uv (px) and depth z (m), the body at the identity pose.
Eigen::Vector3d BeaconAt(const RigCamera& cam, const Eigen::Vector2d& uv, double z) {
  Eigen::Vector2d x_n;
  EXPECT_EQ(Unproject(cam.intrinsics, uv, &x_n), UnprojectStatus::kOk);
  const Eigen::Vector3d p_k(x_n.x() * z, x_n.y() * z, z);
  return cam.r_b_bk + cam.C_k_b.transpose() * p_k;  // body = world at the identity pose
}

struct View {
  Rig rig;
  testing::Scene scene;
  std::array<Match, 16> matches{};
  int num_matches = 0;
  SolveResult solve;
};

// Beacons at the image points `uv` of cameras `cams` and depths `depth_m` (default 2-3.5 m),
// imaged without noise; every beacon matched to its blob, the pose solved from the truth
// (covariance at kSigmaPx).
void MakeView(const std::vector<int>& cams, const std::vector<Eigen::Vector2d>& uv, View* v,
              const std::vector<double>& depth_m = {}) {
  v->rig = PaperRig();
  v->rig.num_beacons = static_cast<int>(uv.size());
  v->scene = testing::Scene{};
  v->num_matches = 0;
  for (std::size_t i = 0; i < uv.size(); ++i) {
    const RigCamera& cam = v->rig.cameras[static_cast<std::size_t>(cams[i])];
    const double z = i < depth_m.size() ? depth_m[i] : 2.0 + 0.5 * static_cast<double>(i % 4);
    v->rig.beacons_w[i] = BeaconAt(cam, uv[i], z);
    ASSERT_TRUE(testing::AddBlob(v->rig, cams[i], uv[i], static_cast<int>(i), 1000.0F, &v->scene));
    v->matches[i] = Match{static_cast<int>(i), static_cast<int>(i), cams[i]};
    ++v->num_matches;
  }
  SolveOptions o;
  o.sigma_px = kSigmaPx;
  ASSERT_EQ(SolvePose(v->rig, v->scene.blobs.data(), v->scene.num_blobs, v->matches.data(), v->num_matches, BodyPose{},
                      o, &v->solve),
            SolveStatus::kOk);
  ASSERT_TRUE(v->solve.has_covariance);
}

// The chi-square of the solve with `beacon`'s blob replaced by one at uv: the independent
// answer to "does another blob fit this beacon as well?".
double SwappedChi2(const View& v, int beacon, const Eigen::Vector2d& uv) {
  testing::Scene s = v.scene;
  s.blobs[static_cast<std::size_t>(beacon)].uv_px = uv;
  EXPECT_EQ(Unproject(v.rig.cameras[static_cast<std::size_t>(s.blobs[static_cast<std::size_t>(beacon)].camera)].intrinsics,
                      uv, &s.blobs[static_cast<std::size_t>(beacon)].x_n),
            UnprojectStatus::kOk);
  SolveOptions o;
  o.sigma_px = kSigmaPx;
  o.outlier_threshold_px = 0.0;
  o.loss_scale_px = 1e6;  // plain least squares
  SolveResult r;
  if (SolvePose(v.rig, s.blobs.data(), s.num_blobs, v.matches.data(), v.num_matches, v.solve.pose, o, &r) !=
      SolveStatus::kOk)
    return 1e9;
  return 2.0 * r.cost / (kSigmaPx * kSigmaPx);
}

// Four beacons 4 m away close together in camera 0 (a 250 x 550 px patch) and one 1 m away in
// camera 1, as in the view the check was written for: the far beacons leave the body's position
// loose by centimetres, which moves the near beacon's image by tens of pixels. A free blob in camera 1 is called a rival exactly when the pose solved with it
// in the beacon's place fits the noise (the solver's chi-square within the gate; the check adds
// the rival's own noise, so the boundary is compared with a margin).
TEST(IdentitiesTest, ARivalIsABlobTheSolveWouldFitAsWell) {
  static View v;
  MakeView({0, 0, 0, 0, 1}, {{120, 320}, {330, 480}, {335, 850}, {230, 620}, {640, 512}}, &v, {4.0, 4.2, 4.2, 4.1, 1.0});
  ASSERT_TRUE(IdentitiesDecisive(v.rig, v.solve.pose, v.solve.covariance, kSigmaPx, kSigmaPx, v.scene.blobs.data(),
                                 v.scene.num_blobs, v.matches.data(), v.num_matches, kGate));
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> angle(0.0, 2.0 * kPi), radius(1.0, 300.0);
  int rivals = 0, agree = 0, compared = 0;
  double farthest_rival_px = 0.0;
  for (int trial = 0; trial < 400; ++trial) {
    const double a = angle(rng), r = radius(rng);
    const Eigen::Vector2d uv = Eigen::Vector2d(640, 512) + r * Eigen::Vector2d(std::cos(a), std::sin(a));
    if (uv.x() < 0.0 || uv.x() > 1279.0 || uv.y() < 0.0 || uv.y() > 1023.0) continue;
    testing::Scene with = v.scene;
    ASSERT_TRUE(testing::AddBlob(v.rig, 1, uv, -1, 1000.0F, &with));
    IdentityRival rival;
    const bool decisive = IdentitiesDecisive(v.rig, v.solve.pose, v.solve.covariance, kSigmaPx, kSigmaPx,
                                             with.blobs.data(), with.num_blobs, v.matches.data(), v.num_matches,
                                             kGate, &rival);
    const double chi2 = SwappedChi2(v, 4, uv);
    rivals += !decisive;
    if (!decisive) farthest_rival_px = std::max(farthest_rival_px, r);
    if (!decisive) {
      EXPECT_EQ(rival.beacon, 4);
      EXPECT_EQ(rival.rival_blob, with.num_blobs - 1);
    }
    if (chi2 < 0.5 * kGate || chi2 > 2.0 * kGate) {  // clear of the boundary
      ++compared;
      agree += decisive == (chi2 > kGate);
      EXPECT_EQ(decisive, chi2 > kGate) << "rival at " << r << " px, angle " << a << ": solver chi-square " << chi2;
    }
  }
  std::printf("one beacon in camera 1: %d of 400 blobs 1-300 px away are rivals, the farthest %.0f px; %d of %d clear "
              "cases agree with the solver\n", rivals, farthest_rival_px, agree, compared);
  EXPECT_GT(compared, 300);
  EXPECT_GT(farthest_rival_px, 50.0);  // the weak direction reaches far
  EXPECT_LT(rivals, 200);              // and not every direction does
}

// Many beacons over three cameras: each one is pinned by the others to a fraction of a pixel,
// and a reflection 8 px beside a beacon is no rival; 0.5 px beside it is.
TEST(IdentitiesTest, AWellSpreadPoseKeepsItsBeaconsFromReflections) {
  static View v;
  MakeView({0, 0, 0, 1, 1, 1, 2, 2, 2},
           {{300, 250}, {950, 300}, {600, 800}, {250, 600}, {1000, 200}, {800, 900}, {640, 300}, {200, 800},
            {1100, 700}},
           &v);
  for (const double offset_px : {8.0, 0.5}) {
    testing::Scene with = v.scene;
    ASSERT_TRUE(testing::AddBlob(v.rig, 1, Eigen::Vector2d(1000.0 + offset_px, 200.0), -1, 500.0F, &with));
    const bool decisive = IdentitiesDecisive(v.rig, v.solve.pose, v.solve.covariance, kSigmaPx, kSigmaPx,
                                             with.blobs.data(), with.num_blobs, v.matches.data(), v.num_matches, kGate);
    EXPECT_EQ(decisive, offset_px > 2.0) << offset_px << " px";
  }
}

TEST(IdentitiesTest, BadInputIsNotDecisive) {
  static View v;
  MakeView({0, 0, 0, 1}, {{300, 250}, {950, 300}, {400, 800}, {640, 512}}, &v);
  const auto decisive = [&](const Eigen::Matrix<double, 6, 6>& cov, double sigma, const Match* m, int n) {
    return IdentitiesDecisive(v.rig, v.solve.pose, cov, sigma, sigma, v.scene.blobs.data(), v.scene.num_blobs, m, n,
                              kGate);
  };
  EXPECT_TRUE(decisive(v.solve.covariance, kSigmaPx, v.matches.data(), v.num_matches));
  Eigen::Matrix<double, 6, 6> nan = v.solve.covariance;
  nan(2, 2) = std::nan("");
  EXPECT_FALSE(decisive(nan, kSigmaPx, v.matches.data(), v.num_matches));
  EXPECT_FALSE(decisive(Eigen::Matrix<double, 6, 6>::Zero(), kSigmaPx, v.matches.data(), v.num_matches));
  EXPECT_FALSE(decisive(v.solve.covariance, 0.0, v.matches.data(), v.num_matches));
  std::array<Match, 1> bad{Match{99, 0, 0}};
  EXPECT_FALSE(decisive(v.solve.covariance, kSigmaPx, bad.data(), 1));
  bad[0] = Match{0, 400, 0};
  EXPECT_FALSE(decisive(v.solve.covariance, kSigmaPx, bad.data(), 1));
  EXPECT_FALSE(decisive(v.solve.covariance, kSigmaPx, nullptr, 2));
}

}  // namespace
}  // namespace mfns::fw
