#include "firmware/modules/solve/solve.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <array>
#include <cstdio>
#include <random>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "common/testing/numeric_diff.h"
#include "firmware/modules/solve/synthetic_scene.h"
#include "firmware/lib/testing/alloc_counter.h"

namespace mfns::fw {
namespace {

using testing::AngleBetween;
using testing::Scene;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;

// The world point that camera k sees at pixel uv at depth z (m) when the body is at `pose`.
Eigen::Vector3d BeaconAt(const Rig& rig, int k, const BodyPose& pose, const Eigen::Vector2d& uv, double z) {
  const RigCamera& cam = rig.cameras[static_cast<std::size_t>(k)];
  Eigen::Vector2d x_n;
  EXPECT_EQ(Unproject(cam.intrinsics, uv, &x_n), UnprojectStatus::kOk);
  const Eigen::Vector3d p_k = z * Eigen::Vector3d(x_n.x(), x_n.y(), 1.0);
  const Eigen::Vector3d p_b = cam.C_k_b.transpose() * p_k + cam.r_b_bk;
  return pose.C_w_b * p_b + pose.r_w_wb;
}

BodyPose TruePose() {
  BodyPose p;
  p.C_w_b = EulerToMatrix({DegToRad(3.0), DegToRad(-4.0), DegToRad(37.0)}).transpose();
  p.r_w_wb = Eigen::Vector3d(0.02, -0.03, 0.01);
  return p;
}

// A rig whose beacons fall at given pixels of given cameras at the true pose: `per_camera[k]`
// beacons in camera k, spread over the image, 0.5..1 m deep.
Rig SplitRig(const std::array<int, 3>& per_camera, const BodyPose& pose) {
  Rig rig = PaperRig();
  rig.num_beacons = 0;
  const Eigen::Vector2d spots[] = {{300, 250}, {1000, 800}, {950, 200}, {250, 850}, {640, 520}};
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < per_camera[static_cast<std::size_t>(k)]; ++j)
      rig.beacons_w[static_cast<std::size_t>(rig.num_beacons++)] =
          BeaconAt(rig, k, pose, spots[j], 0.5 + 0.1 * (j + k));
  return rig;
}

// Matches for every non-spurious blob of a scene.
int TruthMatches(const Scene& s, std::array<Match, limits::kMaxMatches>* m) {
  int n = 0;
  for (int i = 0; i < s.num_blobs; ++i) {
    const int beacon = s.truth_beacon[static_cast<std::size_t>(i)];
    if (beacon < 0) continue;
    (*m)[static_cast<std::size_t>(n++)] = Match{i, beacon, s.blobs[static_cast<std::size_t>(i)].camera};
  }
  return n;
}

BodyPose Perturb(const BodyPose& p, double angle_deg, double dist_m, std::mt19937_64* rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vec6 d;
  for (int i = 0; i < 6; ++i) d[i] = n(*rng);
  d.head<3>() *= dist_m / d.head<3>().norm();
  d.tail<3>() *= DegToRad(angle_deg) / d.tail<3>().norm();
  return Retract(p, d);
}

// Error of an estimate in the PoseDelta parametrisation: est = Retract(truth, e).
Vec6 PoseError(const BodyPose& truth, const BodyPose& est) {
  Vec6 e;
  e.head<3>() = est.r_w_wb - truth.r_w_wb;
  e.tail<3>() = LogSO3(truth.C_w_b.transpose() * est.C_w_b);
  return e;
}

struct Solved {
  SolveStatus status;
  SolveResult r;
};

TEST(SolveTest, ConvergesToTruthOnEveryPaperYawStepWithThreeBeacons) {
  const Rig rig = PaperRig();
  std::mt19937_64 rng(1);
  static Scene s;
  static SolveResult r;
  std::array<Match, limits::kMaxMatches> m{};
  int solved = 0;
  for (int step = 0; step < 360; ++step) {
    testing::Observe(rig, testing::YawPose(DegToRad(step)), 0.0, &rng, &s);
    if (s.NumVisibleBeacons() < 3) continue;
    const int n = TruthMatches(s, &m);
    const BodyPose start = Perturb(s.pose, 5.0, 0.05, &rng);
    ASSERT_EQ(SolvePose(rig, s.blobs.data(), s.num_blobs, m.data(), n, start, {}, &r), SolveStatus::kOk)
        << "step " << step << " " << ToString(r.status);
    EXPECT_LT((r.pose.r_w_wb - s.pose.r_w_wb).norm(), 1e-9) << "step " << step;
    EXPECT_LT(AngleBetween(r.pose.C_w_b, s.pose.C_w_b), 1e-9) << "step " << step;
    EXPECT_LT(r.rms_px, 1e-6);
    EXPECT_EQ(r.num_beacons, s.NumVisibleBeacons());
    ++solved;
  }
  EXPECT_GE(solved, 300);  // 86% of the 360 steps see >= 3 beacons
}

TEST(SolveTest, BeaconsSplitAcrossCameras) {
  const BodyPose truth = TruePose();
  const std::array<std::array<int, 3>, 5> splits = {{{2, 1, 0}, {1, 1, 1}, {0, 1, 2}, {1, 0, 2}, {2, 2, 2}}};
  std::mt19937_64 rng(2);
  static Scene s;
  static SolveResult r;
  std::array<Match, limits::kMaxMatches> m{};
  for (const auto& split : splits) {
    const Rig rig = SplitRig(split, truth);
    testing::Observe(rig, truth, 0.0, &rng, &s);
    const int n = TruthMatches(s, &m);
    ASSERT_EQ(n, split[0] + split[1] + split[2]);
    for (int trial = 0; trial < 20; ++trial) {
      SolveOptions o;
      o.initial_lambda = trial % 2 == 0 ? 1e-6 : 0.0;  // LM and plain Gauss-Newton
      const BodyPose start = Perturb(truth, 5.0, 0.05, &rng);
      ASSERT_EQ(SolvePose(rig, s.blobs.data(), s.num_blobs, m.data(), n, start, o, &r), SolveStatus::kOk)
          << split[0] << "+" << split[1] << "+" << split[2] << ": " << ToString(r.status);
      EXPECT_LT((r.pose.r_w_wb - truth.r_w_wb).norm(), 1e-9);
      EXPECT_LT(AngleBetween(r.pose.C_w_b, truth.C_w_b), 1e-9);
      for (int k = 0; k < 3; ++k)
        EXPECT_EQ(r.inliers_per_camera[static_cast<std::size_t>(k)], split[static_cast<std::size_t>(k)]);
      EXPECT_TRUE(r.has_covariance);
    }
  }
}

// sigma^2 (J^T J)^-1 with J from central differences of ProjectBeacon through Retract.
Mat6 FiniteDifferenceCovariance(const Rig& rig, const Scene& s, const Match* m, int n,
                                const BodyPose& pose, double sigma) {
  Mat6 H = Mat6::Zero();
  for (int i = 0; i < n; ++i) {
    const RigCamera& cam = rig.cameras[static_cast<std::size_t>(m[i].camera)];
    const Eigen::Vector3d& P = rig.beacons_w[static_cast<std::size_t>(m[i].beacon)];
    auto f = [&](const Vec6& d) {
      Eigen::Vector2d uv;
      EXPECT_EQ(ProjectBeacon(cam, Retract(pose, d), P, &uv), ProjectStatus::kOk);
      return uv;
    };
    const Eigen::Matrix<double, 2, 6> J = mfns::testing::CentralDiff<2, 6>(f, Vec6::Zero(), 1e-6);
    H += J.transpose() * J;
  }
  (void)s;
  return sigma * sigma * H.inverse();
}

TEST(SolveTest, CovarianceEqualsFiniteDifferenceInverseFisher) {
  const BodyPose truth = TruePose();
  std::mt19937_64 rng(3);
  static Scene s;
  static SolveResult r;
  std::array<Match, limits::kMaxMatches> m{};
  for (const auto& split : std::array<std::array<int, 3>, 3>{{{1, 1, 1}, {2, 1, 0}, {2, 2, 1}}}) {
    const Rig rig = SplitRig(split, truth);
    testing::Observe(rig, truth, 0.0, &rng, &s);
    const int n = TruthMatches(s, &m);
    SolveOptions o;
    o.sigma_px = 0.7;
    ASSERT_EQ(SolvePose(rig, s.blobs.data(), s.num_blobs, m.data(), n, truth, o, &r), SolveStatus::kOk);
    const Mat6 expected = FiniteDifferenceCovariance(rig, s, m.data(), n, r.pose, o.sigma_px);
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j)
        EXPECT_NEAR(r.covariance(i, j), expected(i, j),
                    1e-5 * std::sqrt(expected(i, i) * expected(j, j)))
            << i << "," << j;
  }
}

// Monte Carlo: the scatter of the estimate equals the reported covariance (Cramer-Rao bound).
void CheckScatterMatchesCovariance(const std::array<int, 3>& split, double sigma, int trials) {
  const BodyPose truth = TruePose();
  const Rig rig = SplitRig(split, truth);
  std::mt19937_64 rng(4);
  static Scene s;
  static SolveResult r;
  std::array<Match, limits::kMaxMatches> m{};
  SolveOptions o;
  o.sigma_px = sigma;
  Mat6 scatter = Mat6::Zero();
  Mat6 mean_cov = Mat6::Zero();
  double nees = 0.0;
  for (int t = 0; t < trials; ++t) {
    testing::Observe(rig, truth, sigma, &rng, &s);
    const int n = TruthMatches(s, &m);
    ASSERT_EQ(SolvePose(rig, s.blobs.data(), s.num_blobs, m.data(), n, Perturb(truth, 2.0, 0.02, &rng), o, &r),
              SolveStatus::kOk);
    ASSERT_EQ(r.num_inliers, n);  // no inlier lost to the outlier test at this noise
    const Vec6 e = PoseError(truth, r.pose);
    scatter += e * e.transpose();
    mean_cov += r.covariance;
    nees += e.dot(r.covariance.ldlt().solve(e));
  }
  scatter /= trials;
  mean_cov /= trials;
  nees /= trials;
  for (int i = 0; i < 6; ++i)
    EXPECT_NEAR(scatter(i, i) / mean_cov(i, i), 1.0, 0.15) << "axis " << i;
  // NEES ~ chi2(6): mean 6, standard error sqrt(12 / trials) (0.11 at 1000 trials).
  EXPECT_NEAR(nees, 6.0, 0.5);
  std::printf("split %d+%d+%d sigma %.2f px, %d trials: scatter/covariance", split[0], split[1], split[2], sigma, trials);
  for (int i = 0; i < 6; ++i) std::printf(" %.3f", scatter(i, i) / mean_cov(i, i));
  std::printf(", mean NEES %.3f\n", nees);
}

TEST(SolveTest, ScatterMatchesCovarianceSixBeacons) {
  CheckScatterMatchesCovariance({2, 2, 2}, 0.3, testing::Trials(3000, 1000));
}

TEST(SolveTest, ScatterMatchesCovarianceThreeBeaconsOnePerCamera) {
  CheckScatterMatchesCovariance({1, 1, 1}, 0.2, testing::Trials(3000, 1000));
}

Rig EightBeaconRig(const BodyPose& truth) { return SplitRig({3, 3, 2}, truth); }

void CheckOutlierRejected(RobustLoss loss) {
  const BodyPose truth = TruePose();
  const Rig rig = EightBeaconRig(truth);
  std::mt19937_64 rng(5);
  static Scene s;
  static SolveResult r, clean;
  std::array<Match, limits::kMaxMatches> m{};
  for (int bad = 0; bad < 8; ++bad) {
    testing::Observe(rig, truth, 0.2, &rng, &s);
    const int n = TruthMatches(s, &m);
    SolveOptions o;
    o.loss = loss;
    // Reference: the same observations without the bad one.
    std::array<Match, limits::kMaxMatches> m_clean{};
    int n_clean = 0;
    for (int i = 0; i < n; ++i)
      if (i != bad) m_clean[static_cast<std::size_t>(n_clean++)] = m[static_cast<std::size_t>(i)];
    ASSERT_EQ(SolvePose(rig, s.blobs.data(), s.num_blobs, m_clean.data(), n_clean, truth, o, &clean),
              SolveStatus::kOk);
    // The outlier: 20 px off in a random direction.
    const double a = 0.7 * bad;
    s.blobs[static_cast<std::size_t>(m[static_cast<std::size_t>(bad)].blob)].uv_px += 20.0 * Eigen::Vector2d(std::cos(a), std::sin(a));
    ASSERT_EQ(SolvePose(rig, s.blobs.data(), s.num_blobs, m.data(), n, Perturb(truth, 5.0, 0.05, &rng), o, &r),
              SolveStatus::kOk)
        << ToString(r.status);
    EXPECT_EQ(r.outlier_rounds, 1);
    EXPECT_FALSE(r.inlier[static_cast<std::size_t>(bad)]);
    EXPECT_GT(r.residual_px[static_cast<std::size_t>(bad)], 15.0);
    EXPECT_EQ(r.num_inliers, n - 1);
    EXPECT_LT((r.pose.r_w_wb - clean.pose.r_w_wb).norm(), 1e-9);
    EXPECT_LT(AngleBetween(r.pose.C_w_b, clean.pose.C_w_b), 1e-9);
    EXPECT_LT((r.covariance - clean.covariance).norm(), 1e-6 * clean.covariance.norm());
  }
}

// Per-beacon map sigmas (issue 16 item 2): beacons surveyed 20x better than the map's worst
// weigh more. The observations carry each beacon's own map error as image noise (k sigma_b px
// beside the centroid noise): the weighted solve's scatter is its covariance scaled to the
// whole error (1 + (k beacon_sigma / sigma_px)^2, as the navigator publishes it), and smaller
// than the unweighted solve's. With every beacon at the map's sigma the weights are all 1 and
// the solve is the unweighted one, bit for bit.
TEST(SolveTest, PerBeaconSigmasWeighTheSolveAndItsCovariance) {
  const BodyPose truth = TruePose();
  Rig rig = EightBeaconRig(truth);
  rig.beacon_sigma = 1e-3;
  rig.has_beacon_sigmas = true;
  for (int b = 0; b < rig.num_beacons; ++b) rig.beacon_sigmas[static_cast<std::size_t>(b)] = b % 2 == 0 ? 5e-5 : 1e-3;
  SolveOptions weighted;
  weighted.sigma_px = 0.1;
  weighted.outlier_threshold_px = 0.0;  // the map errors here reach 6 px: no rejection
  weighted.beacon_px_per_m = 1600.0;    // px/rad at 1 m
  SolveOptions plain = weighted;
  plain.beacon_px_per_m = 0.0;
  const double k = weighted.beacon_px_per_m * rig.beacon_sigma / weighted.sigma_px;
  const double scale = 1.0 + k * k;
  std::mt19937_64 rng(9);
  std::normal_distribution<double> unit(0.0, 1.0);
  static Scene s;
  static SolveResult rw, rp;
  std::array<Match, limits::kMaxMatches> m{};
  const int trials = testing::Trials(2000, 600);
  double nees = 0.0, err2_weighted = 0.0, err2_plain = 0.0;
  for (int t = 0; t < trials; ++t) {
    testing::Observe(rig, truth, 0.0, &rng, &s);
    const int n = TruthMatches(s, &m);
    for (int i = 0; i < n; ++i) {
      const Match& mi = m[static_cast<std::size_t>(i)];
      const double sigma = std::hypot(weighted.sigma_px, weighted.beacon_px_per_m * rig.beacon_sigmas[static_cast<std::size_t>(mi.beacon)]);
      s.blobs[static_cast<std::size_t>(mi.blob)].uv_px += sigma * Eigen::Vector2d(unit(rng), unit(rng));
    }
    ASSERT_EQ(SolvePose(rig, s.blobs.data(), s.num_blobs, m.data(), n, truth, weighted, &rw), SolveStatus::kOk);
    ASSERT_EQ(SolvePose(rig, s.blobs.data(), s.num_blobs, m.data(), n, truth, plain, &rp), SolveStatus::kOk);
    const Vec6 ew = PoseError(truth, rw.pose), ep = PoseError(truth, rp.pose);
    nees += ew.dot((scale * rw.covariance).ldlt().solve(ew));
    err2_weighted += ew.head<3>().squaredNorm();
    err2_plain += ep.head<3>().squaredNorm();
  }
  nees /= trials;
  std::printf("weighted NEES %.3f, position RMS weighted %.3f mm, unweighted %.3f mm\n", nees,
              1e3 * std::sqrt(err2_weighted / trials), 1e3 * std::sqrt(err2_plain / trials));
  EXPECT_NEAR(nees, 6.0, 0.6);
  EXPECT_LT(err2_weighted, 0.7 * err2_plain);
  // Every beacon at the map's sigma: weights 1, the unweighted solve exactly.
  for (int b = 0; b < rig.num_beacons; ++b) rig.beacon_sigmas[static_cast<std::size_t>(b)] = rig.beacon_sigma;
  testing::Observe(rig, truth, 0.3, &rng, &s);
  const int n = TruthMatches(s, &m);
  const BodyPose start = Perturb(truth, 2.0, 0.02, &rng);
  ASSERT_EQ(SolvePose(rig, s.blobs.data(), s.num_blobs, m.data(), n, start, weighted, &rw), SolveStatus::kOk);
  ASSERT_EQ(SolvePose(rig, s.blobs.data(), s.num_blobs, m.data(), n, start, plain, &rp), SolveStatus::kOk);
  EXPECT_EQ(rw.pose.r_w_wb, rp.pose.r_w_wb);
  EXPECT_EQ(rw.covariance, rp.covariance);
}

TEST(SolveTest, OutlierRejectedHuber) { CheckOutlierRejected(RobustLoss::kHuber); }
TEST(SolveTest, OutlierRejectedCauchy) { CheckOutlierRejected(RobustLoss::kCauchy); }

TEST(SolveTest, TooFewBeacons) {
  const BodyPose truth = TruePose();
  const Rig rig = SplitRig({1, 1, 1}, truth);
  std::mt19937_64 rng(6);
  static Scene s;
  static SolveResult r;
  std::array<Match, limits::kMaxMatches> m{};
  testing::Observe(rig, truth, 0.0, &rng, &s);
  ASSERT_EQ(TruthMatches(s, &m), 3);
  for (int n = 0; n < 3; ++n)
    EXPECT_EQ(SolvePose(rig, s.blobs.data(), s.num_blobs, m.data(), n, truth, {}, &r),
              SolveStatus::kTooFewObservations);
  SolveOptions four;
  four.min_beacons = 4;
  EXPECT_EQ(SolvePose(rig, s.blobs.data(), s.num_blobs, m.data(), 3, truth, four, &r),
            SolveStatus::kTooFewObservations);
}

TEST(SolveTest, OneBeaconInTwoCamerasCountsOnce) {
  // Camera y and camera z both observe beacon 0 (placed between their optic axes, in front of
  // both); with beacon 1 that is 3 observations of 2 beacons.
  const BodyPose truth = TruePose();
  Rig rig = SplitRig({0, 1, 1}, truth);
  const Eigen::Vector3d axis_b = rig.cameras[1].C_k_b.row(2).transpose() + rig.cameras[2].C_k_b.row(2).transpose();
  rig.beacons_w[0] = truth.C_w_b * (0.8 * axis_b.normalized()) + truth.r_w_wb;
  static Scene s;
  s = Scene{};
  Eigen::Vector2d uv;
  for (int k = 1; k < 3; ++k) {
    ASSERT_EQ(ProjectBeacon(rig.cameras[static_cast<std::size_t>(k)], truth, rig.beacons_w[0], &uv),
              ProjectStatus::kOk);
    s.blobs[static_cast<std::size_t>(s.num_blobs)].camera = k;
    s.blobs[static_cast<std::size_t>(s.num_blobs++)].uv_px = uv;
  }
  ASSERT_EQ(ProjectBeacon(rig.cameras[2], truth, rig.beacons_w[1], &uv), ProjectStatus::kOk);
  s.blobs[static_cast<std::size_t>(s.num_blobs)].camera = 2;
  s.blobs[static_cast<std::size_t>(s.num_blobs++)].uv_px = uv;
  const std::array<Match, 3> m = {Match{0, 0, 1}, Match{1, 0, 2}, Match{2, 1, 2}};
  static SolveResult r;
  EXPECT_EQ(SolvePose(rig, s.blobs.data(), s.num_blobs, m.data(), 3, truth, {}, &r),
            SolveStatus::kTooFewObservations);
}

TEST(SolveTest, CollinearBeaconsAreSingular) {
  const BodyPose truth = TruePose();
  Rig rig = PaperRig();
  // Four beacons on one line through camera x's field of view.
  const Eigen::Vector3d a = BeaconAt(rig, 0, truth, {300, 300}, 0.6);
  const Eigen::Vector3d b = BeaconAt(rig, 0, truth, {1000, 700}, 0.9);
  rig.num_beacons = 4;
  for (int i = 0; i < 4; ++i) rig.beacons_w[static_cast<std::size_t>(i)] = a + (b - a) * (i / 3.0);
  std::mt19937_64 rng(7);
  static Scene s;
  static SolveResult r;
  std::array<Match, limits::kMaxMatches> m{};
  testing::Observe(rig, truth, 0.0, &rng, &s);
  const int n = TruthMatches(s, &m);
  ASSERT_EQ(n, 4);
  EXPECT_EQ(SolvePose(rig, s.blobs.data(), s.num_blobs, m.data(), n, Perturb(truth, 1.0, 0.01, &rng), {}, &r),
            SolveStatus::kSingular);
  EXPECT_FALSE(r.has_covariance);
}

TEST(SolveTest, StatusesForBadInputsAndLimits) {
  const BodyPose truth = TruePose();
  const Rig rig = SplitRig({2, 1, 1}, truth);
  std::mt19937_64 rng(8);
  static Scene s;
  static SolveResult r;
  std::array<Match, limits::kMaxMatches> m{};
  testing::Observe(rig, truth, 0.0, &rng, &s);
  const int n = TruthMatches(s, &m);
  ASSERT_EQ(n, 4);
  const BodyPose start = Perturb(truth, 5.0, 0.05, &rng);
  auto solve = [&](const std::array<Match, limits::kMaxMatches>& mm, const BodyPose& p, const SolveOptions& o) {
    return SolvePose(rig, s.blobs.data(), s.num_blobs, mm.data(), n, p, o, &r);
  };
  EXPECT_EQ(solve(m, start, {}), SolveStatus::kOk);
  auto bad = m;
  bad[0].beacon = rig.num_beacons;
  EXPECT_EQ(solve(bad, start, {}), SolveStatus::kBadInput);
  bad = m;
  bad[0].camera = (m[0].camera + 1) % 3;  // not the blob's camera
  EXPECT_EQ(solve(bad, start, {}), SolveStatus::kBadInput);
  bad = m;
  bad[1].blob = m[0].blob;  // one blob used twice
  EXPECT_EQ(solve(bad, start, {}), SolveStatus::kBadInput);
  bad = m;
  bad[2].blob = -1;
  EXPECT_EQ(solve(bad, start, {}), SolveStatus::kBadInput);
  EXPECT_EQ(SolvePose(rig, s.blobs.data(), s.num_blobs, m.data(), limits::kMaxMatches + 1, start, {}, &r),
            SolveStatus::kBadInput);
  BodyPose nan_pose = start;
  nan_pose.r_w_wb.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(solve(m, nan_pose, {}), SolveStatus::kNonFinite);
  // Initial attitude turned round: the beacons are behind their cameras.
  BodyPose behind = truth;
  behind.C_w_b = truth.C_w_b * ExpSO3(Eigen::Vector3d(0.0, 0.0, kPi));
  behind.C_w_b = truth.C_w_b * ExpSO3(Eigen::Vector3d(kPi, 0.0, 0.0));
  EXPECT_EQ(solve(m, behind, {}), SolveStatus::kBehindCamera);
  SolveOptions short_leash;
  short_leash.max_travel_m = 1e-3;
  EXPECT_EQ(solve(m, start, short_leash), SolveStatus::kDiverged);
  SolveOptions one_step;
  one_step.max_iterations = 1;
  EXPECT_EQ(solve(m, start, one_step), SolveStatus::kNotConverged);
  SolveOptions bad_o;
  bad_o.sigma_px = 0.0;
  const char* why = nullptr;
  EXPECT_FALSE(bad_o.IsValid(&why));
  EXPECT_STREQ(why, "sigma_px");
  EXPECT_EQ(solve(m, start, bad_o), SolveStatus::kBadInput);
  bad_o = {};
  bad_o.max_iterations = limits::kMaxSolverIterations + 1;
  EXPECT_FALSE(bad_o.IsValid(&why));
  EXPECT_STREQ(why, "max_iterations");
  bad_o = {};
  bad_o.min_beacons = 2;
  EXPECT_FALSE(bad_o.IsValid(&why));
  EXPECT_TRUE(SolveOptions{}.IsValid(&why));
  for (int i = 0; i < kNumSolveStatus; ++i)
    EXPECT_STRNE(ToString(static_cast<SolveStatus>(i)), "unknown solve status");
  SolveCounters counters;
  solve(m, start, {});
  counters.Record(r);
  EXPECT_EQ(counters.by_status[0], 1U);
}

TEST(SolveTest, NoHeapAllocationOverManySolves) {
  const BodyPose truth = TruePose();
  const Rig rig = SplitRig({2, 2, 2}, truth);
  std::mt19937_64 rng(9);
  static Scene s;
  static SolveResult r;
  std::array<Match, limits::kMaxMatches> m{};
  testing::Observe(rig, truth, 0.3, &rng, &s);
  const int n = TruthMatches(s, &m);
  s.blobs[0].uv_px.x() += 20.0;  // exercise the outlier path too
  const BodyPose start = Perturb(truth, 5.0, 0.05, &rng);
  const std::uint64_t before = testing::AllocationCount();
  int ok = 0;
  for (int i = 0; i < testing::Trials(2000, 200); ++i)
    ok += SolvePose(rig, s.blobs.data(), s.num_blobs, m.data(), n, start, {}, &r) == SolveStatus::kOk;
  EXPECT_EQ(testing::AllocationCount() - before, 0u);
  EXPECT_EQ(ok, testing::Trials(2000, 200));
}

}  // namespace
}  // namespace mfns::fw
