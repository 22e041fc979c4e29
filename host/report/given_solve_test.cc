#include "host/report/given_solve.h"

#include <gtest/gtest.h>

#include <cstdio>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "host/report/pose_errors.h"
#include "host/report/report_test_util.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

// A render directory written here by projecting the paper rig's beacons (common/rig model) at
// yaws 0, 7, 14, ... deg: truth.csv and blobs.csv with exact centres. Returns the number of
// frame sets with >= 3 beacons in view.
int WriteSweep(const std::filesystem::path& d, const Rig& rig, int frames) {
  std::string truth = "frame,t_ns,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg\n";
  std::string blobs = "frame,camera,beacon,u_px,v_px,u_geom_px,v_geom_px\n";
  int three = 0;
  for (int f = 0; f < frames; ++f) {
    const double yaw = 7.0 * f;
    BodyPose pose;
    pose.C_w_b = EulerToMatrix(EulerAngles{0.0, 0.0, DegToRad(yaw)}).transpose();
    char line[256];
    std::snprintf(line, sizeof(line), "%d,%d,0,0,0,0,0,%.6f\n", f, 1000 * f, yaw);
    truth += line;
    int seen = 0;
    for (int c = 0; c < rig.num_cameras; ++c)
      for (int b = 0; b < rig.num_beacons; ++b) {
        const RigCamera& cam = rig.cameras[static_cast<std::size_t>(c)];
        Eigen::Vector2d uv;
        if (ProjectBeacon(cam, pose, rig.beacons_w[static_cast<std::size_t>(b)], &uv) != ProjectStatus::kOk) continue;
        if (!InImage(cam.intrinsics, uv)) continue;
        std::snprintf(line, sizeof(line), "%d,%s,%d,%.9f,%.9f,%.9f,%.9f\n", f, cam.name.data(), b, uv.x(), uv.y(),
                      uv.x(), uv.y());
        blobs += line;
        ++seen;
      }
    three += seen >= 3;
  }
  WriteText(d / "truth.csv", truth);
  WriteText(d / "blobs.csv", blobs);
  return three;
}

TEST(GivenSolve, RecoversTheTruePoseFromExactCorrespondences) {
  const auto d = FreshTestDir("given");
  const Rig rig = PaperRig();
  const int three = WriteSweep(d, rig, 52);
  ASSERT_GT(three, 30);
  const GivenSolveSummary s = SolveGivenCorrespondences(d, rig, {}, d / "poses.csv");
  EXPECT_EQ(s.frames, 52);
  EXPECT_EQ(s.fixes, three);
  EXPECT_EQ(s.lost, 52 - three);
  const PoseSummary sum = SummarizePoses(LoadPoseSeries(d / "truth.csv", d / "poses.csv", ""), false);
  EXPECT_EQ(sum.used, three);
  for (int a = 0; a < 6; ++a) EXPECT_LT(sum.axes[static_cast<std::size_t>(a)].rms, 1e-3) << kPoseAxes[static_cast<std::size_t>(a)];
}

TEST(GivenSolve, ABiasedBeaconMapGivesAProportionateError) {
  const auto d = FreshTestDir("given");
  const Rig truth = PaperRig();
  WriteSweep(d, truth, 30);
  Rig believed = truth;
  // The whole map shifted 1 mm along x: the body appears shifted +1 mm (to within the
  // solver's tolerance), attitude unchanged.
  for (int b = 0; b < believed.num_beacons; ++b) believed.beacons_w[static_cast<std::size_t>(b)].x() += 0.001;
  SolveGivenCorrespondences(d, believed, {}, d / "poses.csv");
  const PoseSummary sum = SummarizePoses(LoadPoseSeries(d / "truth.csv", d / "poses.csv", ""), false);
  ASSERT_GT(sum.used, 10);
  EXPECT_NEAR(sum.axes[0].mean, 1.0, 1e-3);
  EXPECT_NEAR(sum.axes[1].mean, 0.0, 1e-3);
  EXPECT_LT(sum.axes[5].rms, 1e-5);
}

TEST(GivenSolve, RefusesUnknownCamerasAndBeacons) {
  const auto d = FreshTestDir("given");
  WriteText(d / "truth.csv", "frame,t_ns,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg\n0,1,0,0,0,0,0,0\n");
  WriteText(d / "blobs.csv", "frame,camera,beacon,u_px,v_px,u_geom_px,v_geom_px\n0,q,1,1,1,1,1\n");
  EXPECT_THROW(SolveGivenCorrespondences(d, PaperRig(), {}, d / "p.csv"), UserError);
  WriteText(d / "blobs.csv", "frame,camera,beacon,u_px,v_px,u_geom_px,v_geom_px\n0,x,10,1,1,1,1\n");
  EXPECT_THROW(SolveGivenCorrespondences(d, PaperRig(), {}, d / "p.csv"), UserError);
}

}  // namespace
}  // namespace mfns::host
