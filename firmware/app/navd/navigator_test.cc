#include "firmware/app/navd/navigator.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"

namespace mfns::fw {
namespace {

struct Scene {
  std::vector<BlobObs> blobs;
  std::vector<int> beacon_of_blob;  // -1: spurious
  int visible = 0;
};

// Blobs of every visible beacon (centroid noise sigma_px) plus `spurious` random blobs.
Scene Observe(const Rig& rig, const BodyPose& pose, double sigma_px, int spurious, std::mt19937_64& rng) {
  std::normal_distribution<double> noise(0.0, sigma_px);
  std::uniform_real_distribution<double> u(20.0, 1260.0), v(20.0, 1004.0);
  std::uniform_int_distribution<int> cam(0, rig.num_cameras - 1);
  Scene s;
  const auto add = [&](int k, const Eigen::Vector2d& uv, int beacon) {
    BlobObs o;
    o.camera = k;
    o.uv_px = uv;
    if (Unproject(rig.cameras[static_cast<std::size_t>(k)].intrinsics, uv, &o.x_n) != UnprojectStatus::kOk) return;
    o.flux = 1000.0F;
    s.blobs.push_back(o);
    s.beacon_of_blob.push_back(beacon);
  };
  for (int k = 0; k < rig.num_cameras; ++k)
    for (int b = 0; b < rig.num_beacons; ++b) {
      Eigen::Vector2d uv;
      const RigCamera& c = rig.cameras[static_cast<std::size_t>(k)];
      if (ProjectBeacon(c, pose, rig.beacons_w[static_cast<std::size_t>(b)], &uv) != ProjectStatus::kOk ||
          !InImage(c.intrinsics, uv))
        continue;
      ++s.visible;
      add(k, uv + Eigen::Vector2d(noise(rng), noise(rng)), b);
    }
  for (int i = 0; i < spurious; ++i) add(cam(rng), Eigen::Vector2d(u(rng), v(rng)), -1);
  return s;
}

BodyPose Yaw(double deg) {
  BodyPose p;
  p.C_w_b = R3(DegToRad(deg)).transpose();
  return p;
}

struct SweepResult {
  int frames_3plus = 0, fixes_3plus = 0, wrong = 0, fixes = 0;
};

SweepResult Sweep(int spurious, int step_deg, std::uint64_t seed) {
  const Rig rig = PaperRig();
  Navigator nav;
  NavigatorOptions opt;
  opt.track.solve.sigma_px = 0.1;
  const char* why = nullptr;
  EXPECT_TRUE(nav.Init(rig, opt, &why)) << (why ? why : "");
  std::mt19937_64 rng(seed);
  SweepResult r;
  NavOutput out;
  for (int i = 0; i * step_deg < 360; ++i) {
    const BodyPose truth = Yaw(i * step_deg);
    const Scene s = Observe(rig, truth, 0.1, spurious, rng);
    nav.Step(s.blobs.data(), static_cast<int>(s.blobs.size()), 1'000'000'000ull + static_cast<std::uint64_t>(i) * 53763441ull,
             false, &out);
    if (s.visible >= 3) ++r.frames_3plus;
    if (out.status == NavStatus::kLost) continue;
    ++r.fixes;
    if (s.visible >= 3) ++r.fixes_3plus;
    // A fix is right when its pose is right and every identity it used is the truth.
    bool right = (out.pose.r_w_wb - truth.r_w_wb).norm() < 0.01 &&
                 LogSO3(out.pose.C_w_b.transpose() * truth.C_w_b).norm() < DegToRad(0.5);
    for (int m = 0; m < out.num_matches; ++m) {
      const Match& mt = out.matches[static_cast<std::size_t>(m)];
      right = right && s.beacon_of_blob[static_cast<std::size_t>(mt.blob)] == mt.beacon;
    }
    if (!right) ++r.wrong;
  }
  return r;
}

TEST(Navigator, YawSweepFixesEveryFrameSetWithThreeBeacons) {
  const SweepResult r = Sweep(0, 1, 1);
  EXPECT_GT(r.frames_3plus, 300);
  EXPECT_EQ(r.fixes_3plus, r.frames_3plus);
  EXPECT_EQ(r.wrong, 0);
}

TEST(Navigator, SpuriousBlobsNeverGiveAWrongFix) {
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    const SweepResult r = Sweep(2, 1, seed);
    EXPECT_EQ(r.wrong, 0) << "seed " << seed;
    EXPECT_GT(r.fixes_3plus, 0.9 * r.frames_3plus) << "seed " << seed;
  }
}

TEST(Navigator, ReacquiresAfterGapsWithoutTracking) {
  // 10 deg steps: tracking gates are left behind often; lost-in-space must carry the sweep.
  const SweepResult r = Sweep(0, 10, 4);
  EXPECT_EQ(r.fixes_3plus, r.frames_3plus);
  EXPECT_EQ(r.wrong, 0);
}

TEST(Navigator, LostWithTooFewBlobsAndCameraDownDegrades) {
  const Rig rig = PaperRig();
  Navigator nav;
  ASSERT_TRUE(nav.Init(rig, NavigatorOptions{}));
  NavOutput out;
  std::vector<BlobObs> two(2);
  two[0].camera = 0;
  two[1].camera = 1;
  nav.Step(two.data(), 2, 1000, false, &out);
  EXPECT_EQ(out.status, NavStatus::kLost);
  EXPECT_EQ(out.reason, NavReason::kTooFewBeacons);
  std::mt19937_64 rng(5);
  for (int deg = 0; deg < 360; ++deg) {
    const Scene s = Observe(rig, Yaw(deg), 0.1, 0, rng);
    if (s.visible < 4) continue;
    nav.Step(s.blobs.data(), static_cast<int>(s.blobs.size()), 2000, true, &out);
    EXPECT_EQ(out.status, NavStatus::kDegraded);
    EXPECT_EQ(out.reason, NavReason::kCameraDown);
    return;
  }
  FAIL() << "no frame set with 4 beacons";
}

}  // namespace
}  // namespace mfns::fw
