#include "host/view/view_state.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/camera/camera.h"
#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"

namespace mfns::host {
namespace {

using nlohmann::json;

fw::PoseRecord Record(const Eigen::Vector3d& r, const Eigen::Matrix3d& C_w_b) {
  fw::PoseRecord p;
  p.frame_set = 17;
  p.t_capture_ns = 2'500'000'000;
  p.status = fw::NavStatus::kFix;
  p.reason = fw::NavReason::kNone;
  p.num_cameras = 3;
  p.num_beacons = 5;
  p.beacons_per_camera = {2, 0, 3, 0};
  p.r_w_wb = r;
  p.q_w_b = Eigen::Quaterniond(C_w_b);
  p.covariance = Eigen::Matrix<double, 6, 6>::Identity() * 1e-8;
  p.covariance(1, 1) = 4e-6;  // y: 2 mm, the largest position sigma
  p.covariance(3, 3) = 1.0;   // attitude: not a position sigma
  return p;
}

TEST(ViewState, APoseDatagramIsShownInWorldFrameMetresAndMillimetreSigma) {
  const Eigen::Matrix3d C_w_b = ExpSO3(Eigen::Vector3d(0.1, -0.4, 2.0));
  const ViewPose p = ViewPoseFromRecord(Record(Eigen::Vector3d(0.3, -1.2, 0.05), C_w_b));
  ASSERT_TRUE(p.has_pose);
  EXPECT_EQ(p.status, "fix");
  EXPECT_EQ(p.frame_set, 17u);
  EXPECT_LT((p.C_w_b - C_w_b).norm(), 1e-12);
  EXPECT_NEAR(p.sigma_mm, 2.0, 1e-9);
  EXPECT_EQ(p.beacons_per_camera[2], 3);
  EXPECT_EQ(p.beacons_per_camera[3], -1);  // the rig has three cameras
}

TEST(ViewState, ALostFrameSetHasNoPoseAndLeavesTheTrail) {
  ViewState state(PaperRig(), "test");
  state.AddPose(ViewPoseFromRecord(Record(Eigen::Vector3d(0.1, 0.2, 0.3), Eigen::Matrix3d::Identity())));
  fw::PoseRecord lost;
  lost.status = fw::NavStatus::kLost;
  lost.reason = fw::NavReason::kTooFewBeacons;
  lost.r_w_wb.setConstant(std::nan(""));
  lost.q_w_b.coeffs().setConstant(std::nan(""));
  state.AddPose(ViewPoseFromRecord(lost));
  const json j = json::parse(state.Json().dump());  // what the page gets, read back
  EXPECT_EQ(j["pose"]["status"], "lost");
  EXPECT_EQ(j["pose"]["reason"], "too few beacons");
  EXPECT_FALSE(j["pose"]["has_pose"].get<bool>());
  EXPECT_FALSE(j["pose"].contains("r_w_wb"));
  ASSERT_EQ(j["trail"].size(), 1u);
  EXPECT_DOUBLE_EQ(j["trail"][0][2].get<double>(), 0.3);
  EXPECT_EQ(j["counts"]["fix"], 1);
  EXPECT_EQ(j["counts"]["lost"], 1);
}

TEST(ViewState, TheTrailKeepsTheNewestPositions) {
  ViewState state(PaperRig(), "test", ViewOptions{.max_trail = 3, .cone_depth_m = 0.4});
  for (int i = 0; i < 5; ++i)
    state.AddPose(ViewPoseFromRecord(Record(Eigen::Vector3d(i, 0, 0), Eigen::Matrix3d::Identity())));
  const json j = state.Json();
  ASSERT_EQ(j["trail"].size(), 3u);
  EXPECT_EQ(j["trail"][0][0].get<double>(), 2.0);
  EXPECT_EQ(j["trail"][2][0].get<double>(), 4.0);
}

// Each cone corner, carried back into its camera and projected by common/camera, lands on the
// image's corner: the cones are drawn from the rig and the pose with the right frames.
TEST(ViewState, ViewConesProjectOntoTheImageCorners) {
  const Rig rig = PaperRig();
  ViewState state(rig, "test");
  const Eigen::Matrix3d C_w_b = ExpSO3(Eigen::Vector3d(0.3, 0.2, -1.1));
  const Eigen::Vector3d r_w_wb(0.4, -0.7, 0.2);
  state.AddPose(ViewPoseFromRecord(Record(r_w_wb, C_w_b)));
  const json cams = state.Json()["pose"]["cameras"];
  ASSERT_EQ(cams.size(), static_cast<std::size_t>(rig.num_cameras));
  for (int k = 0; k < rig.num_cameras; ++k) {
    const RigCamera& cam = rig.cameras[static_cast<std::size_t>(k)];
    const auto corner = [&](int i) {
      const auto& c = cams[static_cast<std::size_t>(k)]["cone_w"][static_cast<std::size_t>(i)];
      return Eigen::Vector3d(c[0].get<double>(), c[1].get<double>(), c[2].get<double>());
    };
    const double w = cam.intrinsics.width, h = cam.intrinsics.height;
    const Eigen::Vector2d expected[4] = {{0, 0}, {w, 0}, {w, h}, {0, h}};
    for (int i = 0; i < 4; ++i) {
      const Eigen::Vector3d p_k = cam.C_k_b * (C_w_b.transpose() * (corner(i) - r_w_wb) - cam.r_b_bk);
      EXPECT_NEAR(p_k.norm(), 0.4, 1e-9);
      Eigen::Vector2d uv;
      ASSERT_EQ(Project(cam.intrinsics, p_k, &uv), ProjectStatus::kOk);
      EXPECT_LT((uv - expected[i]).norm(), 1e-4) << "camera " << k << " corner " << i;
    }
  }
}

TEST(ViewState, HealthAndBadDatagramsAreShown) {
  ViewState state(PaperRig(), "test");
  fw::HealthRecord h;
  h.frame_sets = 40;
  h.fixes = 30;
  h.num_cameras = 3;
  h.cameras[1].state = 1;
  h.cameras[1].timeouts = 4;
  h.worst_frame_set_us = 12345;
  state.SetHealth(h);
  state.CountBadDatagram(fw::MessageStatus::kBadCrc);
  const json j = state.Json();
  EXPECT_EQ(j["health"]["fixes"], 30);
  EXPECT_DOUBLE_EQ(j["health"]["worst_frame_set_ms"].get<double>(), 12.345);
  ASSERT_EQ(j["health"]["cameras"].size(), 3u);
  EXPECT_EQ(j["health"]["cameras"][1]["state"], "set aside");
  EXPECT_EQ(j["health"]["cameras"][1]["timeouts"], 4);
  EXPECT_EQ(j["counts"]["bad_datagrams"], 1);
  EXPECT_EQ(j["counts"]["last_bad"], fw::ToString(fw::MessageStatus::kBadCrc));
  EXPECT_EQ(state.RigJson()["beacons_w"].size(), static_cast<std::size_t>(PaperRig().num_beacons));
}

TEST(ViewState, BlobsAreShownPerCameraWithTheBeaconsUsed) {
  ViewState state(PaperRig(), "test");
  fw::BlobsRecord b;
  b.frame_set = 5;
  b.num_cameras = 3;
  b.num_blobs = 4;
  b.blobs[0] = fw::BlobEntry{2, 7, 100.5f, 200.25f};
  b.blobs[1] = fw::BlobEntry{0, 3, 10.0f, 20.0f};
  b.blobs[2] = fw::BlobEntry{2, -1, 300.0f, 400.0f};
  b.blobs[3] = fw::BlobEntry{5, 1, 1.0f, 1.0f};  // a camera the rig does not have: not shown
  state.SetBlobs(b);
  const json j = state.Json()["blobs"];
  ASSERT_EQ(j["cameras"].size(), 3u);
  EXPECT_EQ(j["cameras"][0].size(), 1u);
  EXPECT_EQ(j["cameras"][1].size(), 0u);
  ASSERT_EQ(j["cameras"][2].size(), 2u);
  EXPECT_EQ(j["cameras"][2][0]["beacon"], 7);
  EXPECT_DOUBLE_EQ(j["cameras"][2][0]["v"].get<double>(), 200.25);
  EXPECT_EQ(j["cameras"][2][1]["beacon"], -1);
  EXPECT_EQ(j["used_beacons"], json::array({7, 3}));
}

}  // namespace
}  // namespace mfns::host
