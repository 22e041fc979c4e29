// The matcher's missing-beacon test against blind cells (issue 14): a camera half saturated (a
// lamp, the sun in a window) must not refute the pose with the beacons its saturated half hides;
// excluded beacons (beacon health) and near misses (a beacon moved since the survey, issue 16).
#include "firmware/modules/identify/match.h"

#include <gtest/gtest.h>

#include <vector>

#include "common/rig/paper_rig.h"

namespace mfns::fw {
namespace {

// The paper rig with four beacons 2 m in front of camera 0 (pose: identity), imaged near
// (200, 300) and (300, 800) in the left part of its 1280 x 1024 image and (1000, 300) and
// (1100, 700) in the right part; blobs: the images of `seen` (camera 0).
class BlindCellsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    rig_ = PaperRig();
    const RigCamera& cam = rig_.cameras[0];
    const CameraIntrinsics& in = cam.intrinsics;
    const double px[4][2] = {{200, 300}, {300, 800}, {1000, 300}, {1100, 700}};
    rig_.num_beacons = 4;
    rig_.has_facing = false;
    for (int m = 0; m < 4; ++m) {
      const Eigen::Vector3d p_k(2.0 * (px[m][0] - in.u0) / in.alpha_x, 2.0 * (px[m][1] - in.v0) / in.alpha_y, 2.0);
      rig_.beacons_w[static_cast<std::size_t>(m)] = cam.C_k_b.transpose() * p_k + cam.r_b_bk;
      ASSERT_EQ(ProjectBeacon(cam, pose_, rig_.beacons_w[static_cast<std::size_t>(m)], &uv_[static_cast<std::size_t>(m)]),
                ProjectStatus::kOk);
    }
    matcher_.Reset(rig_);
  }

  MatchSet Match(const std::vector<int>& seen, std::uint32_t cameras, const MatchOptions& o = MatchOptions{}) {
    blobs_.clear();
    for (int m : seen) {
      BlobObs b;
      b.camera = 0;
      b.uv_px = uv_[static_cast<std::size_t>(m)];
      blobs_.push_back(b);
    }
    return MatchBlobs(cameras, o);
  }
  MatchSet MatchBlobs(std::uint32_t cameras, const MatchOptions& o) {
    matcher_.SetBlobs(blobs_.data(), static_cast<int>(blobs_.size()), cameras);
    MatchSet out;
    matcher_.MatchPose(pose_, o, &out);
    return out;
  }

  Rig rig_;
  BodyPose pose_;
  std::array<Eigen::Vector2d, 4> uv_{};
  std::vector<BlobObs> blobs_;
  BeaconMatcher matcher_;
};

constexpr std::uint32_t kLeftCells = 0b011011;  // columns 0 and 1 of both rows

TEST_F(BlindCellsTest, BeaconsPredictedInBlindCellsAreNotMissing) {
  const MatchSet plain = Match({2, 3}, kAllCameras);  // the left two hidden by glare
  EXPECT_EQ(plain.num_matches, 2);
  EXPECT_EQ(plain.num_predicted, 4);
  EXPECT_EQ(plain.num_missing, 2);  // before: the glare refutes the right pose
  const MatchSet blind = Match({2, 3}, kAllCameras | BlindCellBits(0, kLeftCells));
  EXPECT_EQ(blind.num_matches, 2);
  EXPECT_EQ(blind.num_predicted, 4);
  EXPECT_EQ(blind.num_missing, 0);
}

TEST_F(BlindCellsTest, BlindCellsStillMatchAndOnlyTheirCameraAndCellsCount) {
  const MatchSet seen = Match({0, 2, 3}, kAllCameras | BlindCellBits(0, kLeftCells));
  EXPECT_EQ(seen.num_matches, 3);  // a blob in a blind cell is matched as anywhere
  EXPECT_EQ(seen.num_missing, 0);
  EXPECT_EQ(Match({2, 3}, kAllCameras | BlindCellBits(1, kLeftCells)).num_missing, 2);  // camera 1's cells
  EXPECT_EQ(Match({2, 3}, kAllCameras | BlindCellBits(0, 0b000001)).num_missing, 1);  // (200, 300) in cell 0; (300, 800) in 3
  EXPECT_EQ(Match({0, 1}, kAllCameras | BlindCellBits(0, kLeftCells)).num_missing, 2);  // the right ones
  // The camera set's layout: delivered bits below the cells, six cells per camera.
  EXPECT_EQ(kAllCameras, 0xFu);
  EXPECT_EQ(BlindCellBits(1, 0xFFFFFFFFu), 0x3Fu << 10);
}

// An excluded beacon (beacon health's inconsistent ones, the tracker's leave-one-out) is never
// matched and never missing, wherever its blob is; the others are as before, until the next call.
TEST_F(BlindCellsTest, ExcludedBeaconsAreNeitherMatchedNorMissing) {
  BeaconSet excluded;
  excluded.Set(0);
  excluded.Set(3);
  matcher_.SetExcluded(excluded);
  const MatchSet all = Match({0, 1, 2, 3}, kAllCameras);
  EXPECT_EQ(all.num_matches, 2);
  EXPECT_FALSE(all.beacons.Has(0));
  EXPECT_FALSE(all.beacons.Has(3));
  EXPECT_EQ(all.num_predicted, 2);
  EXPECT_EQ(Match({1, 2}, kAllCameras).num_missing, 0);  // 0 and 3 unseen: not missing
  EXPECT_EQ(Match({2}, kAllCameras).num_missing, 1);     // 1 still is
  matcher_.SetExcluded(BeaconSet{});
  EXPECT_EQ(Match({1, 2}, kAllCameras).num_missing, 2);
  matcher_.SetExcluded(excluded);
  matcher_.Reset(rig_);  // Reset forgets them
  EXPECT_EQ(Match({0, 1, 2, 3}, kAllCameras).num_matches, 4);
}

// A missing beacon with a free blob within near_miss_px of its prediction (a beacon moved since
// the survey: its blob beyond the tight gate) is also a near miss; a blob another beacon matched,
// or one beyond the radius, excuses nothing, and each free blob counts once.
TEST_F(BlindCellsTest, NearMissesNeedAFreeBlobWithinTheirRadius) {
  MatchOptions o;
  o.gate_px = 4.0;
  o.near_miss_px = 15.0;
  for (int m : {0, 1, 2, 3}) {
    BlobObs b;
    b.camera = 0;
    b.uv_px = uv_[static_cast<std::size_t>(m)];
    blobs_.push_back(b);
  }
  blobs_[0].uv_px += Eigen::Vector2d(7.0, -5.0);  // beacon 0 "moved": 8.6 px
  MatchSet s = MatchBlobs(kAllCameras, o);
  EXPECT_EQ(s.num_matches, 3);
  EXPECT_EQ(s.num_missing, 1);
  EXPECT_EQ(s.num_near_missing, 1);
  o.near_miss_px = 0.0;  // not counted
  EXPECT_EQ(MatchBlobs(kAllCameras, o).num_near_missing, 0);
  o.near_miss_px = 8.0;  // beyond the radius
  EXPECT_EQ(MatchBlobs(kAllCameras, o).num_near_missing, 0);
  o.near_miss_px = 15.0;
  // Beacons 0 and 1 missing, a free blob beside 0 only: one near miss.
  blobs_.erase(blobs_.begin() + 1);
  s = MatchBlobs(kAllCameras, o);
  EXPECT_EQ(s.num_missing, 2);
  EXPECT_EQ(s.num_near_missing, 1);
  // Beacon 0 missing, its blob gone: the blobs within any radius are matched to their own
  // beacons and excuse nothing; a free one (a reflection 300 px away) does within 1000 px.
  blobs_.erase(blobs_.begin());
  o.near_miss_px = 1000.0;
  s = MatchBlobs(kAllCameras, o);
  EXPECT_EQ(s.num_matches, 2);
  EXPECT_EQ(s.num_near_missing, 0);
  BlobObs reflection;
  reflection.camera = 0;
  reflection.uv_px = uv_[0] + Eigen::Vector2d(300.0, 0.0);
  blobs_.push_back(reflection);
  EXPECT_EQ(MatchBlobs(kAllCameras, o).num_near_missing, 1);
  EXPECT_EQ(MatchBlobs(kAllCameras, o).num_missing, 2);  // (1 and 0: the reflection matches neither)
}

}  // namespace
}  // namespace mfns::fw
