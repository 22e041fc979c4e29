// Session 21 measurement harness 2 (removed again in the next commit): the power and cost of an
// interval relaxation of the P3P's one-dimensional problem as a pre-filter of a 2+1 view's
// beacon triples (docs/acquisition.md, session 21). Run: build/host/tests/interval_harness_test
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <random>
#include <vector>

#include "common/rotation/rotation.h"
#include "firmware/modules/identify/lost_in_space.h"
#include "firmware/modules/solve/synthetic_scene.h"

namespace mfns::fw {
namespace {

testing::Scene g_scene;

struct Iv {
  double lo, hi;
};

// Range of |p(s) - q(t)| for p on ray a over [a0, a1], q on ray b over [b0, b1] (outer bound:
// min from the closest points of the two segments, max at a corner).
void SegSeg(const BodyRay& ra, Iv A, const BodyRay& rb, Iv B, double* dmin, double* dmax) {
  const Eigen::Vector3d p1 = ra.o_b + A.lo * ra.d_b, p2 = rb.o_b + B.lo * rb.d_b;
  const Eigen::Vector3d e1 = (A.hi - A.lo) * ra.d_b, e2 = (B.hi - B.lo) * rb.d_b;
  const Eigen::Vector3d r = p1 - p2;
  const double a = e1.squaredNorm(), e = e2.squaredNorm(), f = e2.dot(r), c = e1.dot(r), b = e1.dot(e2);
  double s = 0.0, t = 0.0;
  if (a < 1e-18 && e < 1e-18) {
  } else if (a < 1e-18) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else if (e < 1e-18) {
    s = std::clamp(-c / a, 0.0, 1.0);
  } else {
    const double denom = a * e - b * b;
    s = denom > 1e-15 * a * e ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
    t = (b * s + f) / e;
    if (t < 0.0) { t = 0.0; s = std::clamp(-c / a, 0.0, 1.0); }
    else if (t > 1.0) { t = 1.0; s = std::clamp((b - c) / a, 0.0, 1.0); }
  }
  *dmin = ((p1 + s * e1) - (p2 + t * e2)).norm();
  *dmax = std::max(std::max(r.norm(), (r + e1).norm()), std::max((r - e2).norm(), (r + e1 - e2).norm()));
}

// Depth intervals on ray b at distance D from the point o1 + l d1, l in [u, v]: the two branches.
int Branches(const BodyRay& r1, double u, double v, const BodyRay& rb, double D, double tol, Iv lim, Iv* out) {
  // t(l) = (o1 - ob).db + l d1.db ; h2(l) = |o1 - ob + l d1|^2 - t^2
  const Eigen::Vector3d w = r1.o_b - rb.o_b;
  const double t0 = w.dot(rb.d_b), t1 = r1.d_b.dot(rb.d_b);
  const auto h2 = [&](double l) { const double t = t0 + l * t1; return (w + l * r1.d_b).squaredNorm() - t * t; };
  // h2 quadratic: A l^2 + B l + C with A = 1 - t1^2 >= 0
  const double A = 1.0 - t1 * t1, B = 2.0 * (w.dot(r1.d_b) - t0 * t1);
  double hmin = std::min(h2(u), h2(v)), hmax = std::max(h2(u), h2(v));
  if (A > 1e-15) {
    const double lv = -B / (2 * A);
    if (lv > u && lv < v) hmin = std::min(hmin, h2(lv));
  }
  hmin = std::max(0.0, hmin);
  const double Dhi = D + tol, Dlo = std::max(0.0, D - tol);
  if (hmin > Dhi * Dhi) return 0;
  const double smax = std::sqrt(Dhi * Dhi - hmin), smin = std::sqrt(std::max(0.0, Dlo * Dlo - hmax));
  const double tmin = t0 + std::min(u, v) * t1 < t0 + std::max(u, v) * t1 ? t0 + u * t1 : t0 + v * t1;
  const double tlo = std::min(t0 + u * t1, t0 + v * t1), thi = std::max(t0 + u * t1, t0 + v * t1);
  (void)tmin;
  int n = 0;
  const Iv plus{std::max(lim.lo, tlo + smin), std::min(lim.hi, thi + smax)};
  const Iv minus{std::max(lim.lo, tlo - smax), std::min(lim.hi, thi - smin)};
  if (plus.lo <= plus.hi) out[n++] = plus;
  if (minus.lo <= minus.hi) out[n++] = minus;
  return n;
}

// Whether some depths l1 in [lo, hi] (K pieces) and l2, l3 may fit the three distances.
bool IntervalFeasible(const std::array<BodyRay, 3>& r, const std::array<double, 3>& D /*12,13,23*/, double lo, double hi,
                      int K, double tol) {
  const Iv lim{lo, hi};
  for (int p = 0; p < K; ++p) {
    const double u = lo + (hi - lo) * p / K, v = lo + (hi - lo) * (p + 1) / K;
    Iv b2[2], b3[2];
    const int n2 = Branches(r[0], u, v, r[1], D[0], tol, lim, b2);
    if (n2 == 0) continue;
    const int n3 = Branches(r[0], u, v, r[2], D[1], tol, lim, b3);
    for (int x = 0; x < n2; ++x)
      for (int y = 0; y < n3; ++y) {
        double dmin, dmax;
        SegSeg(r[1], b2[x], r[2], b3[y], &dmin, &dmax);
        if (D[2] >= dmin - tol && D[2] <= dmax + tol) return true;
      }
  }
  return false;
}

TEST(IntervalHarness, PowerAndCost) {
  std::mt19937_64 rng(12345);
  static Rig rig;
  for (int map = 0; map < 5; ++map) {
    rig = testing::RandomCylinderRig(64, true, &rng);
    double maxd = 0;
    for (int a = 0; a < rig.num_beacons; ++a)
      for (int b = 0; b < rig.num_beacons; ++b) maxd = std::max(maxd, (rig.beacons_w[a] - rig.beacons_w[b]).norm());
    const double lo_d = 0.1, hi_d = maxd + 0.1;
    P3pOptions po{lo_d, hi_d, 64};
    int got = 0;
    for (int trial = 0; trial < 20000 && got < 3; ++trial) {
      testing::Observe(rig, testing::RandomCylinderPose(&rng), 0.1, &rng, &g_scene);
      if (g_scene.num_blobs != 3) continue;
      int pc[4] = {0, 0, 0, 0};
      for (int i = 0; i < 3; ++i) ++pc[g_scene.blobs[i].camera];
      if (*std::max_element(pc, pc + 4) != 2) continue;
      ++got;
      // Blob order as the search has it (any split): 0, 1, 2.
      std::array<BodyRay, 3> rays;
      for (int i = 0; i < 3; ++i) rays[i] = RayOfBlob(rig, g_scene.blobs[i]);
      double lo[3], hi[3];
      SegmentDistanceRange(rays[0], rays[1], lo_d, hi_d, &lo[0], &hi[0]);
      SegmentDistanceRange(rays[0], rays[2], lo_d, hi_d, &lo[1], &hi[1]);
      SegmentDistanceRange(rays[1], rays[2], lo_d, hi_d, &lo[2], &hi[2]);
      P3pRayTriple tri;
      tri.Set(rays, po);
      const int ta = g_scene.truth_beacon[0], tb = g_scene.truth_beacon[1], tc = g_scene.truth_beacon[2];
      const int nb = rig.num_beacons;
      std::vector<std::array<int, 3>> base;
      for (int a = 0; a < nb; ++a)
        for (int b = 0; b < nb; ++b) {
          if (b == a) continue;
          const double dab = (rig.beacons_w[a] - rig.beacons_w[b]).norm();
          if (dab < lo[0] - 0.01 || dab > hi[0] + 0.01) continue;
          for (int c = 0; c < nb; ++c) {
            if (c == a || c == b) continue;
            const double dac = (rig.beacons_w[a] - rig.beacons_w[c]).norm(), dbc = (rig.beacons_w[b] - rig.beacons_w[c]).norm();
            if (dac < lo[1] - 0.01 || dac > hi[1] + 0.01 || dbc < lo[2] - 0.01 || dbc > hi[2] + 0.01) continue;
            base.push_back({a, b, c});
          }
        }
      // exact: any P3P solution (no workspace test: the relaxation knows none)
      long exact = 0;
      bool truth_exact = false;
      const auto t0 = std::chrono::steady_clock::now();
      for (const auto& h : base) {
        std::array<BodyPose, limits::kMaxP3pSolutions> sol;
        const int ns = tri.Solve({rig.beacons_w[h[0]], rig.beacons_w[h[1]], rig.beacons_w[h[2]]}, &sol);
        if (ns > 0) {
          ++exact;
          truth_exact |= h[0] == ta && h[1] == tb && h[2] == tc;
        }
      }
      const double us_p3p = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count() / base.size();
      std::printf("map %d view %d (split %d+%d+%d): base %zu, any P3P root %ld (%d), %.2f us/solve |", map, got, pc[0], pc[1],
                  pc[2], base.size(), exact, truth_exact, us_p3p);
      for (int K : {2, 4, 8, 16, 32}) {
        long pass = 0;
        bool truth = false;
        const auto t1 = std::chrono::steady_clock::now();
        for (const auto& h : base) {
          const std::array<double, 3> D{(rig.beacons_w[h[0]] - rig.beacons_w[h[1]]).norm(),
                                        (rig.beacons_w[h[0]] - rig.beacons_w[h[2]]).norm(),
                                        (rig.beacons_w[h[1]] - rig.beacons_w[h[2]]).norm()};
          if (IntervalFeasible(rays, D, lo_d, hi_d, K, 0.01)) {
            ++pass;
            truth |= h[0] == ta && h[1] == tb && h[2] == tc;
          }
        }
        const double us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t1).count() / base.size();
        std::printf(" K=%d %ld (%d) %.2f us", K, pass, truth, us);
        EXPECT_TRUE(truth);
      }
      std::printf("\n");
      EXPECT_TRUE(truth_exact);
    }
  }
}

}  // namespace
}  // namespace mfns::fw
