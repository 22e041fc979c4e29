// Session 21's measurement harness (docs/acquisition.md; removed again in the next commit):
// for "2+1" views (two beacons in one camera, one in another, nothing else) of random station
// cylinders, how many ordered beacon triples each candidate test leaves of the one blob triple:
//   base     the search's own tests (segment distance ranges, same-camera co-visibility table)
//   pairA    + the table's angle range for the cross-camera pairs too (0.1 rad more for the lever)
//   cells    + some workspace cell (ball of the cell's half-diagonal + the lever arm) from which
//            the three beacons face the body and every pair's angle lies within the directions'
//            rigorous spread asin(rho / distance) of the observed ray angle
//   p3p      triples with a P3P pose in the module, the three beacons facing it (the exact test)
//   consistent  those poses that predict no other beacon well inside an image
//   clean    (a, b) pairs with a sampled camera position on their angle torus from which camera X
//            sees no other beacon (an optimistic estimate: sampled), and the triples under them
// plus what LostInSpace does with the default budget, with and without the fourth-blob test.
// Run: build/host/tests/two_plus_one_harness_test
#include <gtest/gtest.h>

#include <cstdio>
#include <random>
#include <vector>

#include "common/rotation/rotation.h"
#include "firmware/modules/identify/lost_in_space.h"
#include "firmware/modules/solve/synthetic_scene.h"

namespace mfns::fw {
namespace {

LostInSpace g_lis;
LisResult g_res;
testing::Scene g_scene;

struct Table {
  std::vector<std::vector<float>> cmin, cmax;
};

Table SampleTable(const Rig& rig, double lever) {
  Table t;
  const int nb = rig.num_beacons;
  t.cmin.assign(nb, std::vector<float>(nb, 2.0F));
  t.cmax.assign(nb, std::vector<float>(nb, 2.0F));
  Eigen::Vector3d lo = rig.beacons_w[0], hi = lo;
  for (int m = 0; m < nb; ++m) {
    lo = lo.cwiseMin(rig.beacons_w[m]);
    hi = hi.cwiseMax(rig.beacons_w[m]);
  }
  lo.array() -= lever;
  hi.array() += lever;
  const Eigen::Vector3d size = hi - lo;
  const double step = std::cbrt(size.prod() / 2048);
  int n[3];
  for (int d = 0; d < 3; ++d) n[d] = std::max(1, static_cast<int>(size[d] / step));
  for (int ix = 0; ix < n[0]; ++ix)
    for (int iy = 0; iy < n[1]; ++iy)
      for (int iz = 0; iz < n[2]; ++iz) {
        Eigen::Vector3d p = lo + Eigen::Vector3d((ix + 0.5) * size.x() / n[0], (iy + 0.5) * size.y() / n[1],
                                                 (iz + 0.5) * size.z() / n[2]);
        bool in = true;
        for (int m = 0; m < nb && in && rig.has_facing; ++m) in = rig.beacon_normal_w[m].dot(p - rig.beacons_w[m]) > 0.0;
        if (!in) continue;
        for (int a = 0; a < nb; ++a) {
          Eigen::Vector3d ua = rig.beacons_w[a] - p;
          if (ua.norm() < 0.2 || !BeaconFaces(rig, a, p)) continue;
          ua.normalize();
          for (int b = a + 1; b < nb; ++b) {
            Eigen::Vector3d ub = rig.beacons_w[b] - p;
            if (ub.norm() < 0.2 || !BeaconFaces(rig, b, p)) continue;
            const float c = static_cast<float>(ua.dot(ub.normalized()));
            if (t.cmin[a][b] > 1.5F || c > t.cmin[a][b]) t.cmin[a][b] = c;
            if (t.cmax[a][b] > 1.5F || c < t.cmax[a][b]) t.cmax[a][b] = c;
          }
        }
      }
  return t;
}

bool PairAngleOk(const Table& t, int a, int b, double angle, double tol) {
  const int x = std::min(a, b), y = std::max(a, b);
  const float cmin = t.cmin[x][y], cmax = t.cmax[x][y];
  const float c_lo = static_cast<float>(std::cos(std::min(kPi, angle + tol)));
  const float c_hi = static_cast<float>(std::cos(std::max(0.0, angle - tol)));
  return !(cmin > 1.5F || c_lo > cmin || c_hi < cmax);
}

struct Cells {
  std::vector<Eigen::Vector3d> p;
  double rho = 0;
  // per cell, per beacon: unit dir, delta, visible
  std::vector<std::vector<Eigen::Vector3d>> u;
  std::vector<std::vector<double>> delta;
  std::vector<std::vector<char>> vis;
};

Cells MakeCells(const Rig& rig, int target, double lever) {
  Cells c;
  const int nb = rig.num_beacons;
  Eigen::Vector3d lo = rig.beacons_w[0], hi = lo;
  for (int m = 0; m < nb; ++m) {
    lo = lo.cwiseMin(rig.beacons_w[m]);
    hi = hi.cwiseMax(rig.beacons_w[m]);
  }
  lo.array() -= 0.1;
  hi.array() += 0.1;
  const Eigen::Vector3d size = hi - lo;
  const double step = std::cbrt(size.prod() / target);
  int n[3];
  for (int d = 0; d < 3; ++d) n[d] = std::max(1, static_cast<int>(std::ceil(size[d] / step)));
  const Eigen::Vector3d cell(size.x() / n[0], size.y() / n[1], size.z() / n[2]);
  c.rho = 0.5 * cell.norm() + lever;
  for (int ix = 0; ix < n[0]; ++ix)
    for (int iy = 0; iy < n[1]; ++iy)
      for (int iz = 0; iz < n[2]; ++iz) {
        Eigen::Vector3d p = lo + Eigen::Vector3d((ix + 0.5) * cell.x(), (iy + 0.5) * cell.y(), (iz + 0.5) * cell.z());
        bool in = true;
        for (int m = 0; m < nb && in && rig.has_facing; ++m) in = rig.beacon_normal_w[m].dot(p - rig.beacons_w[m]) > -c.rho;
        if (!in) continue;
        c.p.push_back(p);
        std::vector<Eigen::Vector3d> u(nb);
        std::vector<double> de(nb);
        std::vector<char> vi(nb);
        for (int m = 0; m < nb; ++m) {
          Eigen::Vector3d v = rig.beacons_w[m] - p;
          const double d = v.norm();
          u[m] = v / d;
          de[m] = d <= c.rho ? kPi : std::asin(c.rho / d);
          const double ang = std::acos(std::clamp(rig.beacon_normal_w[m].dot(-u[m]), -1.0, 1.0));
          vi[m] = !rig.has_facing || ang <= rig.beacon_half_angle[m] + de[m];
        }
        c.u.push_back(u);
        c.delta.push_back(de);
        c.vis.push_back(vi);
      }
  return c;
}

bool CellsOk(const Cells& c, int a, int b, int cc, double tab, double tac, double tbc, double tol) {
  for (std::size_t r = 0; r < c.p.size(); ++r) {
    if (!c.vis[r][a] || !c.vis[r][b] || !c.vis[r][cc]) continue;
    auto ok = [&](int x, int y, double th) {
      const double ang = std::acos(std::clamp(c.u[r][x].dot(c.u[r][y]), -1.0, 1.0));
      return std::abs(ang - th) <= c.delta[r][x] + c.delta[r][y] + tol;
    };
    if (ok(a, b, tab) && ok(a, cc, tac) && ok(b, cc, tbc)) return true;
  }
  return false;
}


// Sampled (unsound, an estimate of potential only): is there a camera-X position on the
// torus of (a, b) from which camera X sees no beacon but a and b well inside its image?
bool CleanTorus(const Rig& rig, int camX, int a, int b, const BodyRay& ri, const BodyRay& rj, int steps) {
  const RigCamera& cam = rig.cameras[camX];
  const Eigen::Vector3d A = rig.beacons_w[a], B = rig.beacons_w[b];
  const double dab = (B - A).norm(), th = std::acos(std::clamp(ri.d_b.dot(rj.d_b), -1.0, 1.0));
  const Eigen::Vector3d e1 = (B - A) / dab;
  Eigen::Vector3d e2 = e1.unitOrthogonal(), e3 = e1.cross(e2);
  const Eigen::Vector3d n_b = ri.d_b.cross(rj.d_b).normalized();
  Eigen::Matrix3d F_b;
  F_b << ri.d_b, n_b, ri.d_b.cross(n_b);
  const CameraIntrinsics& in = cam.intrinsics;
  for (int ia = 0; ia < steps; ++ia) {
    const double al = (ia + 0.5) / steps * (kPi - th);
    const double la = dab * std::sin(kPi - th - al) / std::sin(th);
    for (int ip = 0; ip < steps; ++ip) {
      const double ph = (ip + 0.5) / steps * 2 * kPi;
      const Eigen::Vector3d o = A + la * (std::cos(al) * e1 + std::sin(al) * (std::cos(ph) * e2 + std::sin(ph) * e3));
      const Eigen::Vector3d ua = (A - o).normalized(), ub = (B - o).normalized();
      const Eigen::Vector3d n_w = ua.cross(ub).normalized();
      Eigen::Matrix3d F_w;
      F_w << ua, n_w, ua.cross(n_w);
      BodyPose pose;
      pose.C_w_b = F_w * F_b.transpose();
      pose.r_w_wb = o - pose.C_w_b * cam.r_b_bk;
      const Eigen::Vector3d r = pose.r_w_wb;
      if (!(std::abs(r.x()) < 3.1 && r.tail<2>().norm() < 2.2)) continue;
      if (!BeaconFaces(rig, a, o, 0.15) || !BeaconFaces(rig, b, o, 0.15)) continue;
      const Eigen::Matrix3d C_k_w = cam.C_k_b * pose.C_w_b.transpose();
      bool clean = true;
      for (int m = 0; m < rig.num_beacons && clean; ++m) {
        if (m == a || m == b) continue;
        const Eigen::Vector3d pk = C_k_w * (rig.beacons_w[m] - o);
        if (pk.z() <= 0.1) continue;
        const double u = in.alpha_x * pk.x() / pk.z() + in.u0, v = in.alpha_y * pk.y() / pk.z() + in.v0;
        if (u < 15 || v < 15 || u > in.width - 16 || v > in.height - 16) continue;
        if (!BeaconFaces(rig, m, o)) continue;
        clean = false;
      }
      if (clean) return true;
    }
  }
  return false;
}

TEST(TwoPlusOneHarness, PruningPower) {
  std::mt19937_64 rng(12345);
  static Rig rig;
  double lever = 0;
  int views = 0;
  struct Case { int beacons; bool facing; int maps; };
  for (const Case cs : {Case{64, true, 5}, Case{64, false, 2}, Case{128, true, 2}})
  for (int map = 0; map < cs.maps; ++map) {
    std::printf("cylinder %d beacons, facing %d\n", cs.beacons, cs.facing);
    rig = testing::RandomCylinderRig(cs.beacons, cs.facing, &rng);
    ASSERT_TRUE(g_lis.Reset(rig));
    for (int k = 0; k < rig.num_cameras; ++k) lever = std::max(lever, rig.cameras[k].r_b_bk.norm());
    const Table tab = SampleTable(rig, lever);
    std::vector<Cells> cells;
    for (int target : {4096}) cells.push_back(MakeCells(rig, target, lever));
    double maxd = 0;
    for (int a = 0; a < rig.num_beacons; ++a)
      for (int b = 0; b < rig.num_beacons; ++b) maxd = std::max(maxd, (rig.beacons_w[a] - rig.beacons_w[b]).norm());
    P3pOptions po{0.1, maxd + 0.1, 64};
    int got = 0;
    for (int trial = 0; trial < 20000 && got < 3; ++trial) {
      testing::Observe(rig, testing::RandomCylinderPose(&rng), 0.1, &rng, &g_scene);
      if (g_scene.num_blobs != 3) continue;
      int pc[4] = {0, 0, 0, 0};
      for (int i = 0; i < 3; ++i) ++pc[g_scene.blobs[i].camera];
      if (*std::max_element(pc, pc + 4) != 2) continue;
      ++got;
      ++views;
      // blobs i,j same camera, k other
      int bi = -1, bj = -1, bk = -1;
      for (int i = 0; i < 3; ++i) {
        if (pc[g_scene.blobs[i].camera] == 2) (bi < 0 ? bi : bj) = i;
        else bk = i;
      }
      const BodyRay ri = RayOfBlob(rig, g_scene.blobs[bi]), rj = RayOfBlob(rig, g_scene.blobs[bj]),
                    rk = RayOfBlob(rig, g_scene.blobs[bk]);
      const double tij = std::acos(ri.d_b.dot(rj.d_b)), tik = std::acos(ri.d_b.dot(rk.d_b)), tjk = std::acos(rj.d_b.dot(rk.d_b));
      double lo[3], hi[3];
      SegmentDistanceRange(ri, rj, 0.1, maxd + 0.1, &lo[0], &hi[0]);
      SegmentDistanceRange(ri, rk, 0.1, maxd + 0.1, &lo[1], &hi[1]);
      SegmentDistanceRange(rj, rk, 0.1, maxd + 0.1, &lo[2], &hi[2]);
      P3pRayTriple tri;
      tri.Set({ri, rj, rk}, po);
      const int ta = g_scene.truth_beacon[bi], tb = g_scene.truth_beacon[bj], tc = g_scene.truth_beacon[bk];
      long base = 0, pairA = 0, p3p = 0, consistent = 0, pairs = 0, pairs_clean = 0, base_clean = 0;
      bool truth_clean = false;
      std::vector<long> cellc(cells.size(), 0);
      bool truth_base = false, truth_A = false, truth_p3p = false;
      std::vector<bool> truth_cell(cells.size(), false);
      const int nb = rig.num_beacons;
      const double tol = 0.01;
      for (int a = 0; a < nb; ++a)
        for (int b = 0; b < nb; ++b) {
          if (b == a) continue;
          const double dab = (rig.beacons_w[a] - rig.beacons_w[b]).norm();
          if (dab < lo[0] - 0.01 || dab > hi[0] + 0.01 || !PairAngleOk(tab, a, b, tij, tol)) continue;
          const bool clean = CleanTorus(rig, g_scene.blobs[bi].camera, a, b, ri, rj, 32);
          ++pairs;
          pairs_clean += clean;
          if (a == ta && b == tb) truth_clean = clean;
          for (int c = 0; c < nb; ++c) {
            if (c == a || c == b) continue;
            const double dac = (rig.beacons_w[a] - rig.beacons_w[c]).norm(), dbc = (rig.beacons_w[b] - rig.beacons_w[c]).norm();
            if (dac < lo[1] - 0.01 || dac > hi[1] + 0.01 || dbc < lo[2] - 0.01 || dbc > hi[2] + 0.01) continue;
            const bool truth = a == ta && b == tb && c == tc;
            ++base;
            base_clean += clean;
            truth_base |= truth;
            const double ltol = tol + 2 * std::asin(std::min(1.0, lever / 0.1));  // crude
            (void)ltol;
            if (PairAngleOk(tab, a, c, tik, tol + 0.1) && PairAngleOk(tab, b, c, tjk, tol + 0.1)) {
              ++pairA;
              truth_A |= truth;
            }
            for (std::size_t q = 0; q < cells.size(); ++q)
              if (CellsOk(cells[q], a, b, c, tij, tik, tjk, tol)) {
                ++cellc[q];
                if (truth) truth_cell[q] = true;
              }
            std::array<BodyPose, limits::kMaxP3pSolutions> sol;
            const int ns = tri.Solve({rig.beacons_w[a], rig.beacons_w[b], rig.beacons_w[c]}, &sol);
            bool any = false;
            for (int s = 0; s < ns; ++s) {
              const Eigen::Vector3d r = sol[s].r_w_wb;
              if (std::abs(r.x()) < 3.1 && r.tail<2>().norm() < 2.2 && BeaconFaces(rig, a, r, 0.15) &&
                  BeaconFaces(rig, b, r, 0.15) && BeaconFaces(rig, c, r, 0.15)) {
                any = true;
                bool refuted = false;
                for (int k = 0; k < rig.num_cameras && !refuted; ++k)
                  for (int m = 0; m < nb && !refuted; ++m) {
                    if (m == a || m == b || m == c) continue;
                    const RigCamera& cam = rig.cameras[k];
                    if (!BeaconFaces(rig, m, sol[s].C_w_b * cam.r_b_bk + r)) continue;
                    const Eigen::Vector3d pk = WorldToCamera(cam, sol[s], rig.beacons_w[m]);
                    if (pk.z() <= 0.1) continue;
                    Eigen::Vector2d uv;
                    if (ProjectBeacon(cam, sol[s], rig.beacons_w[m], &uv) != ProjectStatus::kOk) continue;
                    if (InImage(cam.intrinsics, uv, 15.0)) refuted = true;
                  }
                if (!refuted) ++consistent;
              }
            }
            if (any) {
              ++p3p;
              truth_p3p |= truth;
            }
          }
        }
      LisOptions o;
      auto truth_in = [&]() {
        for (int q = 0; q < g_res.num_consistent; ++q)
          if ((g_res.consistent_poses[q].r_w_wb - g_scene.pose.r_w_wb).norm() < 0.05) return 1;
        return 0;
      };
      o.fourth_blob_min_beacons = 1000;
      g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, o, &g_res);
      std::printf("no4th: hyp %d complete %d n %d truth %d | ", g_res.hypotheses, g_res.complete, g_res.num_consistent, truth_in());
      o.fourth_blob_min_beacons = 32;
      g_lis.Identify(g_scene.blobs.data(), g_scene.num_blobs, o, &g_res);
      std::printf("4th: n %d truth %d | ", g_res.num_consistent, truth_in());
      std::printf("map %d view %d: lis hyp %d complete %d | base %ld (%d) pairA %ld (%d) cells", map, got, g_res.hypotheses,
                  g_res.complete, base, truth_base, pairA, truth_A);
      for (std::size_t q = 0; q < cells.size(); ++q)
        std::printf(" [%zu cells rho %.2f] %ld (%d)", cells[q].p.size(), cells[q].rho, cellc[q], static_cast<int>(truth_cell[q]));
      EXPECT_TRUE(truth_base && truth_A && truth_p3p && truth_clean);
      for (std::size_t q = 0; q < cells.size(); ++q) EXPECT_TRUE(truth_cell[q]);
      std::printf(" | p3p %ld (%d) consistent %ld | pairs %ld clean %ld (%d) triples under clean %ld\n", p3p, truth_p3p, consistent, pairs, pairs_clean, truth_clean, base_clean);
    }
  }
  std::printf("lever %.3f\n", lever);
  EXPECT_GT(views, 0);
}

}  // namespace
}  // namespace mfns::fw
