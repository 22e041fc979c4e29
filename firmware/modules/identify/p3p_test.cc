#include "firmware/modules/identify/p3p.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <random>

#include "firmware/modules/identify/p3p_scan_reference.h"

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "firmware/modules/solve/synthetic_scene.h"

#ifdef MFNS_HAVE_OPENCV
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#endif

namespace mfns::fw {
namespace {

using testing::AngleBetween;

// A blob of camera k at pixel uv and the world point at distance `range` (m) along its ray.
struct Shot {
  BlobObs blob;
  Eigen::Vector3d P_w;
};

Shot ShotAt(const Rig& rig, int k, const BodyPose& pose, const Eigen::Vector2d& uv, double range) {
  Shot s;
  s.blob.camera = k;
  s.blob.uv_px = uv;
  EXPECT_EQ(Unproject(rig.cameras[static_cast<std::size_t>(k)].intrinsics, uv, &s.blob.x_n), UnprojectStatus::kOk);
  const BodyRay ray = RayOfBlob(rig, s.blob);
  s.P_w = pose.C_w_b * (ray.o_b + range * ray.d_b) + pose.r_w_wb;
  return s;
}

struct Trial {
  std::array<BodyRay, 3> rays;
  std::array<Eigen::Vector3d, 3> P_w;
  BodyPose truth;
};

// Three blobs in random cameras (any split) of the paper rig at a random pose.
Trial RandomTrial(const Rig& rig, std::mt19937_64* rng, int force_camera = -1) {
  std::uniform_int_distribution<int> cam(0, 2);
  std::uniform_real_distribution<double> u(20.0, 1260.0), v(20.0, 1004.0), range(0.3, 3.0);
  Trial t;
  t.truth = testing::RandomBoxPose(rng);
  for (std::size_t i = 0; i < 3; ++i) {
    const int k = force_camera >= 0 ? force_camera : cam(*rng);
    const Shot s = ShotAt(rig, k, t.truth, {u(*rng), v(*rng)}, range(*rng));
    t.rays[i] = RayOfBlob(rig, s.blob);
    t.P_w[i] = s.P_w;
  }
  return t;
}

bool ContainsTruth(const std::array<BodyPose, limits::kMaxP3pSolutions>& sols, int n, const BodyPose& truth,
                   double tol) {
  for (int s = 0; s < n; ++s) {
    const BodyPose& p = sols[static_cast<std::size_t>(s)];
    if ((p.r_w_wb - truth.r_w_wb).norm() < tol && AngleBetween(p.C_w_b, truth.C_w_b) < tol) return true;
  }
  return false;
}

// Every solution must put each beacon on its ray (the pose reproduces the three blobs).
void ExpectAllSolutionsConsistent(const Trial& t, const std::array<BodyPose, limits::kMaxP3pSolutions>& sols,
                                  int n) {
  for (int s = 0; s < n; ++s) {
    const BodyPose& p = sols[static_cast<std::size_t>(s)];
    EXPECT_TRUE(IsRotation(p.C_w_b, 1e-9));
    for (std::size_t i = 0; i < 3; ++i) {
      const Eigen::Vector3d q = p.C_w_b.transpose() * (t.P_w[i] - p.r_w_wb) - t.rays[i].o_b;
      EXPECT_GT(q.dot(t.rays[i].d_b), 0.0);
      EXPECT_LT(q.cross(t.rays[i].d_b).norm(), 1e-7) << "solution " << s << " ray " << i;
    }
  }
}

void CheckRecovery(int force_camera, std::uint64_t seed) {
  const Rig rig = PaperRig();
  std::mt19937_64 rng(seed);
  P3pOptions o;
  o.min_depth_m = 0.1;
  o.max_depth_m = 4.0;
  P3pRayTriple triple;
  std::array<BodyPose, limits::kMaxP3pSolutions> sols;
  const int trials = testing::Trials(2000, 300);
  int found = 0, total_solutions = 0;
  for (int i = 0; i < trials; ++i) {
    const Trial t = RandomTrial(rig, &rng, force_camera);
    ASSERT_TRUE(triple.Set(t.rays, o));
    const int n = triple.Solve(t.P_w, &sols);
    total_solutions += n;
    found += ContainsTruth(sols, n, t.truth, 1e-7);
    ExpectAllSolutionsConsistent(t, sols, n);
  }
  // The scan may miss a root only where two solutions nearly merge (about 1 in 10^4 here).
  EXPECT_LE(trials - found, 1 + trials / 1000) << "of " << trials;
  std::printf("camera %d: truth found in %d of %d trials, %.2f solutions per triple\n", force_camera, found, trials,
              static_cast<double>(total_solutions) / trials);
}

TEST(P3pTest, RecoversPoseFromRaysOfAnyCameraSplit) { CheckRecovery(-1, 11); }
TEST(P3pTest, RecoversPoseFromOneCamera) { CheckRecovery(1, 12); }

// Polynomials built from known roots: every real root is found (a double root too), complex
// pairs give none.
TEST(P3pTest, PolynomialRealRootsFindsEveryRealRoot) {
  std::mt19937_64 rng(16);
  std::uniform_real_distribution<double> u(-5.0, 5.0);
  auto expand = [](const std::array<double, 4>& r, double lead, std::array<double, 5>* c) {
    // lead * prod (x - r_i), lowest coefficient first.
    *c = {lead, 0.0, 0.0, 0.0, 0.0};
    for (int i = 0; i < 4; ++i) {
      for (int k = i + 1; k >= 1; --k) (*c)[static_cast<std::size_t>(k)] = (*c)[static_cast<std::size_t>(k - 1)] - r[static_cast<std::size_t>(i)] * (*c)[static_cast<std::size_t>(k)];
      (*c)[0] = -r[static_cast<std::size_t>(i)] * (*c)[0];
    }
  };
  for (int trial = 0; trial < 2000; ++trial) {
    std::array<double, 4> r = {u(rng), u(rng), u(rng), u(rng)};
    if (trial % 4 == 1) r[1] = r[0];  // a double root
    std::array<double, 5> c{};
    expand(r, 0.5 + std::abs(u(rng)), &c);
    std::array<double, 4> found{};
    const int n = PolynomialRealRoots(c.data(), 4, found.data());
    std::sort(r.begin(), r.end());
    for (double x : r) {
      bool hit = false;
      for (int i = 0; i < n; ++i) hit = hit || std::abs(found[static_cast<std::size_t>(i)] - x) < 1e-6;
      EXPECT_TRUE(hit) << "trial " << trial << " root " << x;
    }
    for (int i = 0; i + 1 < n; ++i) EXPECT_LT(found[static_cast<std::size_t>(i)], found[static_cast<std::size_t>(i + 1)]);
  }
  // (x^2 + 1)(x^2 + 4): no real root; (x^2 + 1)(x - 2)(x + 3): two.
  const double none[5] = {4.0, 0.0, 5.0, 0.0, 1.0};
  double roots[4];
  EXPECT_EQ(PolynomialRealRoots(none, 4, roots), 0);
  const double two[5] = {-6.0, 1.0, -5.0, 1.0, 1.0};
  ASSERT_EQ(PolynomialRealRoots(two, 4, roots), 2);
  EXPECT_NEAR(roots[0], -3.0, 1e-12);
  EXPECT_NEAR(roots[1], 2.0, 1e-12);
}

// The central closed form (one camera) against the general (octic) solve on the same rays with
// their origins moved apart by 1e-9 m (which takes the general path): the same solutions.
TEST(P3pTest, CentralClosedFormMatchesTheGeneralScan) {
  const Rig rig = PaperRig();
  std::mt19937_64 rng(17);
  P3pOptions o;
  o.min_depth_m = 0.1;
  o.max_depth_m = 4.0;
  P3pRayTriple central, general;
  std::array<BodyPose, limits::kMaxP3pSolutions> a, b;
  int closed_total = 0, scan_total = 0, missing = 0;
  const int trials = testing::Trials(2000, 300);
  for (int i = 0; i < trials; ++i) {
    const Trial t = RandomTrial(rig, &rng, i % 3);
    std::array<BodyRay, 3> moved = t.rays;
    moved[1].o_b.x() += 1e-9;
    moved[2].o_b.y() += 1e-9;
    ASSERT_TRUE(central.Set(t.rays, o));
    ASSERT_TRUE(general.Set(moved, o));
    const int n = central.Solve(t.P_w, &a);
    const int m = general.Solve(t.P_w, &b);
    closed_total += n;
    scan_total += m;
    ExpectAllSolutionsConsistent(t, a, n);
    for (int j = 0; j < m; ++j) missing += !ContainsTruth(a, n, b[static_cast<std::size_t>(j)], 1e-5);
  }
  std::printf("closed form %d solutions, scan %d, scan's not in the closed form's %d\n", closed_total, scan_total,
              missing);
  EXPECT_LE(missing, 1 + trials / 1000);
  EXPECT_GE(closed_total, scan_total - trials / 1000);
}

// Every solution of the solver before the algebraic one (p3p_scan_reference.h: Grunert's
// quartic for one camera, the 1-D scan for several) is among the new solver's, to 1e-6 (m and
// rad); the truth to 1e-7; the new ones the old lacked still reproduce the three rays.
void CheckAgainstScanReference(int force_camera, std::uint64_t seed, double min_depth, double max_depth) {
  const Rig rig = PaperRig();
  std::mt19937_64 rng(seed);
  P3pOptions o;
  o.min_depth_m = min_depth;
  o.max_depth_m = max_depth;
  P3pRayTriple ours;
  scan_reference::ScanP3p old;
  std::array<BodyPose, limits::kMaxP3pSolutions> a, b;
  const int trials = testing::Trials(20000, 2000);
  int ours_total = 0, old_total = 0, missing = 0, truth_missing = 0, old_truth_missing = 0;
  for (int i = 0; i < trials; ++i) {
    const Trial t = RandomTrial(rig, &rng, force_camera);
    ASSERT_TRUE(ours.Set(t.rays, o));
    ASSERT_TRUE(old.Set(t.rays, o));
    const int n = ours.Solve(t.P_w, &a);
    const int m = old.Solve(t.P_w, &b);
    ours_total += n;
    old_total += m;
    ExpectAllSolutionsConsistent(t, a, n);
    for (int j = 0; j < m; ++j) {
      const bool found = ContainsTruth(a, n, b[static_cast<std::size_t>(j)], 1e-6);
      missing += !found;
      EXPECT_TRUE(found) << "trial " << i << " old solution " << j;
    }
    truth_missing += !ContainsTruth(a, n, t.truth, 1e-7);
    old_truth_missing += !ContainsTruth(b, m, t.truth, 1e-7);
  }
  std::printf("camera %d, depths %.1f-%.1f m: ours %d solutions, old %d, old's not in ours %d; truth missed: ours %d, "
              "old %d (of %d)\n",
              force_camera, min_depth, max_depth, ours_total, old_total, missing, truth_missing, old_truth_missing,
              trials);
  // (No count comparison: the old solver reports some near-double roots twice, 1e-9 apart.)
  EXPECT_EQ(missing, 0);
  EXPECT_EQ(truth_missing, 0);
}

TEST(P3pTest, FindsEveryScanReferenceSolutionAnySplit) { CheckAgainstScanReference(-1, 21, 0.1, 4.0); }
TEST(P3pTest, FindsEveryScanReferenceSolutionOneCamera) { CheckAgainstScanReference(0, 22, 0.1, 4.0); }
TEST(P3pTest, FindsEveryScanReferenceSolutionWideDepths) { CheckAgainstScanReference(-1, 23, 0.05, 10.0); }

// The circle through a triangle's corners (its danger cylinder's cross-section): centre, radius
// and an orthonormal frame (x towards P[0], z the normal). False when the triangle's doubled
// area |e1 x e2| is below min_cross.
struct Circumcircle {
  Eigen::Vector3d centre, x, y, z;
  double radius = 0.0;
};
bool CircumcircleOf(const std::array<Eigen::Vector3d, 3>& P, double min_cross, Circumcircle* c) {
  const Eigen::Vector3d e1 = P[1] - P[0], e2 = P[2] - P[0], nrm = e1.cross(e2);
  if (nrm.norm() < min_cross) return false;
  // Circumcentre: P0 + (|e1|^2 (e2 x n) + |e2|^2 (n x e1)) / (2 |n|^2) with n = e1 x e2.
  c->centre = P[0] + (e1.squaredNorm() * e2.cross(nrm) + e2.squaredNorm() * nrm.cross(e1)) / (2.0 * nrm.squaredNorm());
  c->radius = (P[0] - c->centre).norm();
  c->z = nrm.normalized();
  c->x = (P[0] - c->centre).normalized();
  c->y = c->z.cross(c->x);
  return true;
}

// Near the danger cylinder (the camera centre on the cylinder through the three beacons,
// perpendicular to their plane) two solutions merge: configurations at relative distances
// 1e-2..1e-7 from it, one camera and three cameras (ray origins up to 5 cm apart, the rig's
// scale). The old solver's close pairs (the "twin" root the tracker refuses three-beacon fixes
// by) are all found again; no pose is non-finite or not a rotation. Merging solutions are
// determined to ~sqrt(rounding) only, and at a few metres from a small triangle the residuals
// stay within rounding over ~1e-4 m (both solvers land anywhere there): every old solution and
// the truth have one of ours within 1e-3 (m and rad; the tracker's twin scale is 1e-3), and
// within 1e-5 in >= 99.5 % of the cases.
void CheckNearDangerCylinder(bool multi_camera, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0), ang(0.0, 2.0 * M_PI), lexp(-7.0, -2.0);
  P3pOptions o;
  o.min_depth_m = 0.1;
  o.max_depth_m = 6.0;
  P3pRayTriple ours;
  scan_reference::ScanP3p old;
  std::array<BodyPose, limits::kMaxP3pSolutions> a, b;
  const int trials = testing::Trials(5000, 1000);
  int old_pairs = 0, our_pairs = 0, missing = 0, old_total = 0, ours_total = 0, truth_missing = 0;
  int coarse_missing = 0, truth_coarse = 0, compared = 0;
  auto close_pairs = [](const std::array<BodyPose, limits::kMaxP3pSolutions>& s, int n) {
    int pairs = 0;
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j)
        pairs += (s[static_cast<std::size_t>(i)].r_w_wb - s[static_cast<std::size_t>(j)].r_w_wb).norm() < 2e-2;
    return pairs;
  };
  for (int trial = 0; trial < trials; ++trial) {
    // Beacons on a random triangle, camera centre near its circumscribed cylinder.
    std::array<Eigen::Vector3d, 3> P;
    for (auto& p : P) p = Eigen::Vector3d(u(rng), u(rng), 0.3 * u(rng));
    Circumcircle cyl;
    if (!CircumcircleOf(P, 0.2, &cyl)) continue;
    const Eigen::Vector3d &cc = cyl.centre, &x = cyl.x, &y = cyl.y, &z = cyl.z;
    const double R = cyl.radius;
    const double th = ang(rng), eps = std::pow(10.0, lexp(rng)) * (u(rng) < 0.0 ? -1.0 : 1.0);
    const Eigen::Vector3d centre = cc + R * (1.0 + eps) * (std::cos(th) * x + std::sin(th) * y) + 0.8 * u(rng) * z;
    BodyPose truth;
    truth.C_w_b = testing::RandomRotation(&rng);
    truth.r_w_wb = centre;
    Trial t;
    t.truth = truth;
    t.P_w = P;
    bool ok = true;
    for (std::size_t i = 0; i < 3; ++i) {
      t.rays[i].o_b = multi_camera ? Eigen::Vector3d(0.05 * u(rng), 0.05 * u(rng), 0.05 * u(rng)) : Eigen::Vector3d::Zero();
      const Eigen::Vector3d q = truth.C_w_b.transpose() * (P[i] - truth.r_w_wb) - t.rays[i].o_b;
      ok = ok && q.norm() > 0.15 && q.norm() < 5.5;
      t.rays[i].d_b = q.normalized();
    }
    if (!ok) continue;
    ASSERT_TRUE(ours.Set(t.rays, o));
    ASSERT_TRUE(old.Set(t.rays, o));
    const int n = ours.Solve(t.P_w, &a);
    const int m = old.Solve(t.P_w, &b);
    for (int s = 0; s < n; ++s) {
      ASSERT_TRUE(a[static_cast<std::size_t>(s)].C_w_b.allFinite() && a[static_cast<std::size_t>(s)].r_w_wb.allFinite());
    }
    ExpectAllSolutionsConsistent(t, a, n);
    ours_total += n;
    old_total += m;
    old_pairs += close_pairs(b, m);
    our_pairs += close_pairs(a, n);
    truth_missing += !ContainsTruth(a, n, t.truth, 1e-6);
    truth_coarse += !ContainsTruth(a, n, t.truth, 1e-3);
    for (int j = 0; j < m; ++j) {
      const BodyPose& q = b[static_cast<std::size_t>(j)];
      missing += !ContainsTruth(a, n, q, 1e-5);
      const bool found = ContainsTruth(a, n, q, 1e-3);
      coarse_missing += !found;
      EXPECT_TRUE(found) << "trial " << trial << " eps " << eps << " old solution " << j << " of " << m << ", ours " << n;
    }
    compared += m;
  }
  std::printf("%s near the danger cylinder: ours %d solutions (%d close pairs), old %d (%d close pairs); old's not in "
              "ours within 1e-5: %d, within 1e-3: %d; truth not within 1e-6: %d, 1e-3: %d\n",
              multi_camera ? "three cameras" : "one camera", ours_total, our_pairs, old_total, old_pairs, missing,
              coarse_missing, truth_missing, truth_coarse);
  EXPECT_EQ(coarse_missing, 0);
  EXPECT_EQ(truth_coarse, 0);
  EXPECT_LE(missing, compared / 200);
  EXPECT_LE(truth_missing, trials / 200);
  EXPECT_GE(our_pairs, old_pairs);
}

TEST(P3pTest, NearTheDangerCylinderOneCamera) { CheckNearDangerCylinder(false, 31); }
TEST(P3pTest, NearTheDangerCylinderThreeCameras) { CheckNearDangerCylinder(true, 32); }

// Octics built from known roots (real ones inside and outside the interval, a double root,
// complex pairs): every real root in the interval is found, a double root once at least.
TEST(P3pTest, PolynomialRealRootsInFindsEveryRootInTheInterval) {
  std::mt19937_64 rng(33);
  std::uniform_real_distribution<double> u(-1.0, 6.0), im(0.01, 2.0);
  int double_roots = 0;
  for (int trial = 0; trial < 5000; ++trial) {
    // Quadratic factors x^2 - 2 re x + (re^2 + im^2) or (x - r1)(x - r2).
    std::array<double, 9> c = {1.0, 0, 0, 0, 0, 0, 0, 0, 0};
    std::vector<double> real;
    int deg = 0;
    for (int f = 0; f < 4; ++f) {
      double q[3];
      if (trial % 3 == 0 && f == 3) {  // complex pair
        const double re = u(rng), m = im(rng);
        q[0] = re * re + m * m;
        q[1] = -2.0 * re;
      } else {
        const double r1 = u(rng), r2 = (trial % 4 == 1 && f == 0) ? r1 : u(rng);
        double_roots += r1 == r2;
        real.push_back(r1);
        real.push_back(r2);
        q[0] = r1 * r2;
        q[1] = -(r1 + r2);
      }
      q[2] = 1.0;
      std::array<double, 9> next{};
      for (int i = 0; i <= deg; ++i)
        for (int k = 0; k < 3; ++k) next[static_cast<std::size_t>(i + k)] += c[static_cast<std::size_t>(i)] * q[k];
      c = next;
      deg += 2;
    }
    const double lo = 0.1, hi = 5.0;
    std::array<double, 8> roots{};
    const int n = PolynomialRealRootsIn(c.data(), 8, lo, hi, roots.data());
    ASSERT_LE(n, 8);
    for (int i = 0; i + 1 < n; ++i) EXPECT_LE(roots[static_cast<std::size_t>(i)], roots[static_cast<std::size_t>(i + 1)]);
    for (double r : real) {
      if (r < lo + 1e-6 || r > hi - 1e-6) continue;
      // A simple root is determined to its condition number (terms' magnitude over the
      // slope) times the rounding, here with a 1000x margin (and 1e-9: the P3P polishes its
      // roots); a double root, or one within 1e-2 of others, to ~sqrt or cbrt(rounding x that
      // magnitude) only: 1e-2.
      int copies = 0, within_5cm = 0;
      double nearest_other = 1e9;
      for (double o : real) {
        copies += o == r;
        within_5cm += std::abs(o - r) < 0.05;
        if (o != r) nearest_other = std::min(nearest_other, std::abs(o - r));
      }
      double slope = 0.0, mag = 0.0;
      for (int k = 8; k >= 0; --k) mag = mag * r + std::abs(c[static_cast<std::size_t>(k)]);
      for (int k = 8; k >= 1; --k) slope = slope * r + k * c[static_cast<std::size_t>(k)];
      // Three or more roots within 0.05 (never from a P3P: its multiple roots are at most
      // double near the danger cylinder) may come out as one candidate of the cluster.
      const double tol = within_5cm >= 3                     ? 0.05
                         : copies > 1 || nearest_other < 1e-2 ? 1e-2
                                                              : std::min(1e-3, 1e-9 + 1e-13 * mag / std::abs(slope));
      bool hit = false;
      for (int i = 0; i < n; ++i) hit = hit || std::abs(roots[static_cast<std::size_t>(i)] - r) < tol;
      EXPECT_TRUE(hit) << "trial " << trial << " root " << r;
    }
  }
  EXPECT_GT(double_roots, 1000);
}

TEST(P3pTest, AbsoluteOrientationExactAndRefusesCollinear) {
  std::mt19937_64 rng(13);
  for (int i = 0; i < 100; ++i) {
    const BodyPose truth = testing::RandomBoxPose(&rng);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    std::array<Eigen::Vector3d, 3> q, P;
    for (std::size_t j = 0; j < 3; ++j) {
      q[j] = Eigen::Vector3d(u(rng), u(rng), u(rng));
      P[j] = truth.C_w_b * q[j] + truth.r_w_wb;
    }
    BodyPose est;
    ASSERT_TRUE(AbsoluteOrientation(q, P, &est));
    EXPECT_LT(AngleBetween(est.C_w_b, truth.C_w_b), 1e-12);
    EXPECT_LT((est.r_w_wb - truth.r_w_wb).norm(), 1e-12);
    ASSERT_TRUE(TriangleOrientation(q, P, &est));
    EXPECT_LT(AngleBetween(est.C_w_b, truth.C_w_b), 1e-12);
    EXPECT_LT((est.r_w_wb - truth.r_w_wb).norm(), 1e-12);
    q[2] = q[0] + 2.0 * (q[1] - q[0]);
    P[2] = truth.C_w_b * q[2] + truth.r_w_wb;
    EXPECT_FALSE(AbsoluteOrientation(q, P, &est));
    EXPECT_FALSE(TriangleOrientation(q, P, &est));
  }
}

TEST(P3pTest, SegmentDistanceRangeMatchesDenseSampling) {
  std::mt19937_64 rng(14);
  std::uniform_real_distribution<double> u(-0.2, 0.2);
  const int n = testing::Trials(300, 100);  // grid samples per segment
  for (int i = 0; i < testing::Trials(200, 60); ++i) {
    BodyRay a, b;
    a.o_b = Eigen::Vector3d(u(rng), u(rng), u(rng));
    b.o_b = i % 3 == 0 ? a.o_b : Eigen::Vector3d(u(rng), u(rng), u(rng));
    a.d_b = testing::RandomRotation(&rng).col(2);
    b.d_b = i % 5 == 0 ? a.d_b : testing::RandomRotation(&rng).col(2);
    double lo = 0.0, hi = 0.0;
    SegmentDistanceRange(a, b, 0.2, 3.0, &lo, &hi);
    double smin = 1e9, smax = 0.0;
    for (int x = 0; x <= n; ++x) {
      for (int y = 0; y <= n; ++y) {
        const double la = 0.2 + 2.8 * x / n, lb = 0.2 + 2.8 * y / n;
        const double d = ((a.o_b + la * a.d_b) - (b.o_b + lb * b.d_b)).norm();
        smin = std::min(smin, d);
        smax = std::max(smax, d);
      }
    }
    EXPECT_LE(lo, smin + 1e-12);
    EXPECT_GT(lo, smin - 2.0 * 2.8 / n);  // within two grid spacings of the sampled minimum
    EXPECT_NEAR(hi, smax, 1e-9);
  }
}

// Near-double roots under noise (P3pOptions::near_double_residual): one camera exactly on the
// danger cylinder of three beacons 0.7-3 m away, the true pose a double root; each ray turned
// by centroid-sized noise (1e-4 rad, 0.16 px at f = 1600 px). The noise splits the double root
// into two real ones or turns it into a complex pair; in the second case the exact solve has
// nothing near the truth. With near-double roots kept, the pair's real part is there: many
// more trials have a solution within 3 % of the true depths, and every exact root is kept.
TEST(P3pTest, NearDoubleRootsKeepTheRealPartOfAComplexPair) {
  std::mt19937_64 rng(41);
  std::uniform_real_distribution<double> u(-1.0, 1.0), ang(0.0, 2.0 * M_PI);
  std::normal_distribution<double> noise(0.0, 1e-4);
  P3pOptions exact, near;
  exact.min_depth_m = near.min_depth_m = 0.1;
  exact.max_depth_m = near.max_depth_m = 6.0;
  near.near_double_residual = 1e-3;
  ASSERT_TRUE(near.IsValid());
  P3pRayTriple a, b;
  std::array<BodyPose, limits::kMaxP3pSolutions> sa, sb;
  std::array<Eigen::Vector3d, limits::kMaxP3pSolutions> da, db;
  const auto near_truth = [](const std::array<Eigen::Vector3d, limits::kMaxP3pSolutions>& d, int n,
                             const Eigen::Vector3d& l) {
    for (int s = 0; s < n; ++s)
      if (((d[static_cast<std::size_t>(s)] - l).cwiseAbs().array() / l.array()).maxCoeff() < 0.03) return true;
    return false;
  };
  int trials = 0, found_exact = 0, found_near = 0, more = 0;
  for (int trial = 0; trial < 400; ++trial) {
    std::array<Eigen::Vector3d, 3> P;
    for (auto& p : P) p = Eigen::Vector3d(u(rng), u(rng), 0.2 * u(rng));
    Circumcircle cyl;
    if (!CircumcircleOf(P, 0.3, &cyl)) continue;
    const double th = ang(rng);
    BodyPose truth;
    truth.C_w_b = testing::RandomRotation(&rng);
    truth.r_w_wb = cyl.centre + cyl.radius * (std::cos(th) * cyl.x + std::sin(th) * cyl.y) +
                   (0.5 + 1.5 * std::abs(u(rng))) * cyl.z;
    std::array<BodyRay, 3> rays;
    Eigen::Vector3d l;
    bool ok = true;
    for (std::size_t i = 0; i < 3; ++i) {
      const Eigen::Vector3d q = truth.C_w_b.transpose() * (P[i] - truth.r_w_wb);
      l(static_cast<Eigen::Index>(i)) = q.norm();
      ok = ok && q.norm() > 0.7 && q.norm() < 3.0;
      const Eigen::Vector3d axis = q.unitOrthogonal();
      rays[i].d_b = Eigen::AngleAxisd(noise(rng), axis) * Eigen::AngleAxisd(noise(rng), q.normalized().cross(axis)) *
                    q.normalized();
    }
    if (!ok) continue;
    ASSERT_TRUE(a.Set(rays, exact));
    ASSERT_TRUE(b.Set(rays, near));
    const int na = a.Solve(P, &sa, &da), nb = b.Solve(P, &sb, &db);
    ++trials;
    found_exact += near_truth(da, na, l);
    found_near += near_truth(db, nb, l);
    more += nb > na;
    for (int s = 0; s < na; ++s)  // the exact roots are kept as they were
      EXPECT_TRUE(near_truth(db, nb, da[static_cast<std::size_t>(s)])) << "trial " << trial;
  }
  std::printf("near-double roots: %d trials, truth within 3 %%: %d exact, %d with near-double roots (%d gained roots)\n",
              trials, found_exact, found_near, more);
  ASSERT_GE(trials, 100);
  // (Measured: 83 and 171 of 252. The rest are split pairs, each root centimetres off, which
  // lost-in-space's weak roots handle, or pairs whose real part noise moved as far.)
  EXPECT_LT(found_exact, trials / 2);              // the failure is real
  EXPECT_GE(found_near, found_exact + trials / 5);  // and the real parts recover many
  EXPECT_GT(more, 0);
}

TEST(P3pTest, OptionsValidation) {
  P3pOptions o;
  const char* why = nullptr;
  EXPECT_TRUE(o.IsValid(&why));
  o.scan_steps = limits::kMaxP3pScanSteps + 1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_STREQ(why, "scan_steps");
  o = {};
  o.near_double_residual = -1e-3;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_STREQ(why, "near_double_residual");
  o = {};
  o.max_depth_m = o.min_depth_m;
  EXPECT_FALSE(o.IsValid(&why));
  P3pRayTriple t;
  EXPECT_FALSE(t.Set({}, o));
}

#ifdef MFNS_HAVE_OPENCV
// Independent reference for the central case: OpenCV's P3P (Gao et al.) on one camera with no
// distortion. Every OpenCV solution in the depth range must be among ours.
TEST(P3pTest, CentralCaseContainsOpenCvSolutions) {
  Rig rig = PaperRig();
  for (auto& c : rig.cameras) c.intrinsics.kc = {};
  std::mt19937_64 rng(15);
  P3pOptions o;
  o.min_depth_m = 0.1;
  o.max_depth_m = 6.0;
  P3pRayTriple triple;
  std::array<BodyPose, limits::kMaxP3pSolutions> sols;
  const CameraIntrinsics& in = rig.cameras[0].intrinsics;
  const cv::Matx33d K(in.alpha_x, 0, in.u0, 0, in.alpha_y, in.v0, 0, 0, 1);
  int compared = 0, ours_total = 0, cv_total = 0;
  for (int i = 0; i < 500; ++i) {
    const Trial t = RandomTrial(rig, &rng, 0);
    ASSERT_TRUE(triple.Set(t.rays, o));
    const int n = triple.Solve(t.P_w, &sols);
    // OpenCV wants object points in the camera's "world" = our world; image points in px.
    std::vector<cv::Point3d> obj;
    std::vector<cv::Point2d> img;
    for (std::size_t j = 0; j < 3; ++j) {
      obj.emplace_back(t.P_w[j].x(), t.P_w[j].y(), t.P_w[j].z());
      Eigen::Vector2d uv;
      ASSERT_EQ(ProjectBeacon(rig.cameras[0], t.truth, t.P_w[j], &uv), ProjectStatus::kOk);
      img.emplace_back(uv.x(), uv.y());
    }
    std::vector<cv::Mat> rvecs, tvecs;
    const int m = cv::solveP3P(obj, img, K, cv::noArray(), rvecs, tvecs, cv::SOLVEPNP_P3P);
    ours_total += n;
    for (int s = 0; s < m; ++s) {
      cv::Matx33d R;
      cv::Rodrigues(rvecs[static_cast<std::size_t>(s)], R);
      Eigen::Matrix3d C_k_w;
      cv::cv2eigen(R, C_k_w);
      Eigen::Vector3d t_k;
      cv::cv2eigen(tvecs[static_cast<std::size_t>(s)], t_k);
      // Camera pose -> body pose: C_w_b = C_w_k C_k_b, r_w_wb = r_w_wk - C_w_b r_b_bk.
      BodyPose cvpose;
      cvpose.C_w_b = C_k_w.transpose() * rig.cameras[0].C_k_b;
      cvpose.r_w_wb = -C_k_w.transpose() * t_k - cvpose.C_w_b * rig.cameras[0].r_b_bk;
      bool in_range = true;
      for (std::size_t j = 0; j < 3; ++j) {
        const double range = (C_k_w * t.P_w[j] + t_k).norm();
        in_range = in_range && range >= o.min_depth_m * 1.01 && range <= o.max_depth_m * 0.99;
      }
      if (!in_range) continue;
      ++cv_total;
      // OpenCV's P3P is accurate to ~1e-4 here (ours reproduces the truth to 1e-7, tested
      // above); distinct solutions are far more apart than 1e-3.
      EXPECT_TRUE(ContainsTruth(sols, n, cvpose, 1e-3)) << "trial " << i << " OpenCV solution " << s;
      ++compared;
    }
  }
  EXPECT_GT(compared, 500);
  std::printf("OpenCV P3P solutions %d (all found), ours %d\n", cv_total, ours_total);
}
#endif

}  // namespace
}  // namespace mfns::fw
