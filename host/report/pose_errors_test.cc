#include "host/report/pose_errors.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "common/rotation/rotation.h"

#include "host/report/report_test_util.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

const char* kTruth =
    "frame,t_ns,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg\n"
    "0,100,0,0,0,0,0,0\n"
    "1,200,0,0,0,0,0,1\n"
    "2,300,0,0,0,0,0,2\n"
    "3,400,0,0,0,0,0,3\n"
    "4,500,10,0,0,0,0,359.5\n"
    "5,600,0,0,0,0,0,5\n"
    "6,700,0,0,0,0,0,6\n";

// Errors by design: x = 1, 2, 3, 4, 5 (mean 3, sample std sqrt(2.5)); yaw across the wrap
// (359.5 -> -0.4 is +0.1); frame 5 lost, frame 6 missing, frame 3 degraded.
const char* kPoses =
    "frame,t_ns,status,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg,n_beacons,rms_px\n"
    "0,100,fix,1,-2,0.5,0.01,0,0.1,4,0.2\n"
    "1,200,fix,2,-2,0.5,0.01,0,1.1,3,0.1\n"
    "2,300,fix,3,-2,0.5,0.01,0,2.1,5,0.3\n"
    "3,400,degraded,4,-2,0.5,0.01,0,3.1,3,1.5\n"
    "4,500,fix,15,-2,0.5,0.01,0,-0.4,4,0.2\n"
    "5,600,lost,nan,nan,nan,nan,nan,nan,2,nan\n";

const char* kCrb =
    "frame,t_ns,n_visible,n_x,n_y,n_z,valid,sigma_x_mm,sigma_y_mm,sigma_z_mm,sigma_roll_deg,sigma_pitch_deg,sigma_yaw_deg\n"
    "0,100,4,1,2,1,1,0.3,0.1,0.1,0.01,0.01,0.01\n"
    "1,200,3,1,1,1,1,0.4,0.1,0.1,0.01,0.01,0.01\n"
    "2,300,5,2,2,1,1,0.3,0.1,0.1,0.01,0.01,0.01\n"
    "3,400,3,0,2,1,1,0.4,0.1,0.1,0.01,0.01,0.01\n"
    "4,500,4,1,1,2,1,0.3,0.1,0.1,0.01,0.01,0.01\n"
    "5,600,2,0,1,1,0,nan,nan,nan,nan,nan,nan\n"
    "6,700,3,1,1,1,1,0.3,0.1,0.1,0.01,0.01,0.01\n";

struct Files {
  std::filesystem::path truth, poses, crb;
};

Files Write(const std::filesystem::path& d, const char* poses = kPoses) {
  Files f{d / "truth.csv", d / "poses.csv", d / "crb.csv"};
  WriteText(f.truth, kTruth);
  WriteText(f.poses, poses);
  WriteText(f.crb, kCrb);
  return f;
}

// LoadPoseSeries' UserError message with these poses, or "(no error)".
std::string LoadError(const char* poses) {
  const Files f = Write(FreshTestDir("pose"), poses);
  try {
    LoadPoseSeries(f.truth, f.poses, f.crb);
  } catch (const UserError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(PoseErrors, JoinsFramesAndWrapsAngles) {
  const Files f = Write(FreshTestDir("pose"));
  const PoseSeries s = LoadPoseSeries(f.truth, f.poses, f.crb);
  ASSERT_EQ(s.samples.size(), 7u);
  EXPECT_EQ(s.cameras, (std::vector<std::string>{"x", "y", "z"}));
  EXPECT_NEAR(s.samples[4].error[0], 5.0, 1e-12);
  EXPECT_NEAR(s.samples[4].error[5], 0.1, 1e-9);  // -0.4 - 359.5 wraps to +0.1
  EXPECT_NEAR(s.samples[0].error[1], -2.0, 1e-12);
  EXPECT_EQ(s.samples[3].status, "degraded");
  EXPECT_EQ(s.samples[5].status, "lost");
  EXPECT_EQ(s.samples[6].status, "");
  EXPECT_EQ(s.samples[2].visible_per_camera, (std::vector<int>{2, 2, 1}));
  EXPECT_EQ(s.samples[2].n_beacons, 5);
  EXPECT_FALSE(s.samples[5].bound_valid);
  EXPECT_TRUE(s.samples[6].bound_valid);
}

TEST(PoseErrors, KnownMeanAndStd) {
  const Files f = Write(FreshTestDir("pose"));
  const PoseSummary all = SummarizePoses(LoadPoseSeries(f.truth, f.poses, f.crb), true);
  EXPECT_EQ(all.frames, 7);
  EXPECT_EQ(all.fixes, 4);
  EXPECT_EQ(all.degraded, 1);
  EXPECT_EQ(all.lost, 1);
  EXPECT_EQ(all.missing, 1);
  EXPECT_EQ(all.used, 5);
  EXPECT_EQ(all.frames_3plus, 6);
  EXPECT_EQ(all.posed_3plus, 5);
  EXPECT_NEAR(all.axes[0].mean, 3.0, 1e-12);
  EXPECT_NEAR(all.axes[0].std, std::sqrt(2.5), 1e-12);
  EXPECT_NEAR(all.axes[0].rms, std::sqrt(55.0 / 5.0), 1e-12);
  EXPECT_NEAR(all.axes[1].mean, -2.0, 1e-12);
  EXPECT_NEAR(all.axes[1].std, 0.0, 1e-12);
  EXPECT_NEAR(all.axes[5].mean, 0.1, 1e-9);
  // Bound: sqrt(mean of sigma^2) over the 5 frames used: (0.09 * 3 + 0.16 * 2) / 5.
  EXPECT_NEAR(all.axes[0].bound_rms, std::sqrt((0.09 * 3 + 0.16 * 2) / 5), 1e-12);

  const PoseSummary fix = SummarizePoses(LoadPoseSeries(f.truth, f.poses, f.crb), false);
  EXPECT_EQ(fix.used, 4);
  EXPECT_NEAR(fix.axes[0].mean, (1 + 2 + 3 + 5) / 4.0, 1e-12);
  EXPECT_EQ(fix.fixes_3plus, 4);
  // Worst errors: frame 4, position (5, -2, 0.5), attitude (0.01, 0, 0.1).
  EXPECT_NEAR(fix.worst_position_mm, std::sqrt(25.0 + 4.0 + 0.25), 1e-12);
  // (The rotation angle; at these small angles the norm of the Euler errors to 1e-6.)
  EXPECT_NEAR(fix.worst_attitude_deg, std::sqrt(0.0001 + 0.01), 1e-6);
}

// Near roll -90 deg (2-1-3 angles) pitch and yaw turn about nearly the same axis: an estimate
// 0.02 deg off has pitch and yaw errors of 0.2 deg and more. The attitude error is the angle of
// the rotation between the two attitudes, checked against the estimate made by turning the truth
// by 0.02 deg about a known axis.
TEST(PoseErrors, AttitudeErrorIsTheRotationAngleNearGimbalLock) {
  const EulerAngles truth{DegToRad(-89.2), DegToRad(-46.9), DegToRad(30.0)};
  const Eigen::Matrix3d C_true = EulerToMatrix(truth);
  const Eigen::Matrix3d C_est = R2(DegToRad(0.02)) * C_true;
  const EulerAngles est = MatrixToEuler(C_est);
  char truth_csv[256], poses_csv[256];
  std::snprintf(truth_csv, sizeof(truth_csv), "frame,t_ns,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg\n0,100,0,0,0,%.9f,%.9f,%.9f\n",
                RadToDeg(truth.phi), RadToDeg(truth.theta), RadToDeg(truth.psi));
  std::snprintf(poses_csv, sizeof(poses_csv),
                "frame,t_ns,status,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg,n_beacons,rms_px\n0,100,fix,0,0,0,%.9f,%.9f,%.9f,5,0.1\n",
                RadToDeg(est.phi), RadToDeg(est.theta), RadToDeg(est.psi));
  const std::filesystem::path d = FreshTestDir("gimbal");
  WriteText(d / "truth.csv", truth_csv);
  WriteText(d / "poses.csv", poses_csv);
  const PoseSeries series = LoadPoseSeries(d / "truth.csv", d / "poses.csv", "");
  ASSERT_EQ(series.samples.size(), 1u);
  const PoseSample& s = series.samples[0];
  EXPECT_GT(std::hypot(s.error[4], s.error[5]), 0.2);  // the Euler errors, ten times the rotation
  EXPECT_NEAR(s.attitude_error_deg, 0.02, 1e-5);
  EXPECT_NEAR(SummarizePoses(series, false).worst_attitude_deg, 0.02, 1e-5);
}

// `mfns-sim compare`'s statistics: only frames with a valid bound (a finite one), so that the
// bound's RMS and the errors' are over the same frames.
TEST(PoseErrors, RequireBoundKeepsOnlyFramesWithAValidBound) {
  const auto d = FreshTestDir("pose");
  const Files f = Write(d);
  // Frame 2's bound says valid but is not finite: no bound.
  std::string crb = kCrb;
  crb.replace(crb.find("2,300,5,2,2,1,1,0.3"), 19, "2,300,5,2,2,1,1,inf");
  WriteText(f.crb, crb);
  const PoseSeries s = LoadPoseSeries(f.truth, f.poses, f.crb);
  EXPECT_FALSE(s.samples[2].bound_valid);
  const PoseSummary loose = SummarizePoses(s, false);
  const PoseSummary strict = SummarizePoses(s, false, nullptr, /*require_bound=*/true);
  EXPECT_EQ(loose.used, 4);
  EXPECT_EQ(strict.used, 3);
  EXPECT_EQ(strict.fixes, 4);  // counts cover every sample
  EXPECT_NEAR(strict.axes[0].mean, (1 + 2 + 5) / 3.0, 1e-12);
  EXPECT_NEAR(strict.axes[0].bound_rms, std::sqrt((0.09 + 0.16 + 0.09) / 3), 1e-12);
  EXPECT_EQ(s.pose_rows, 6u);
}

TEST(PoseErrors, RejectsAFrameTwice) {
  const std::string error = LoadError("frame,t_ns,status,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg,n_beacons,rms_px\n"
                                      "0,100,fix,1,2,3,0,0,0,3,0.1\n0,100,fix,1,2,3,0,0,0,3,0.1\n");
  EXPECT_NE(error.find("poses.csv:3: frame 0 appears twice"), std::string::npos) << error;
}

TEST(PoseErrors, CommonFramesRestrictTheStatisticsNotTheCounts) {
  const auto d = FreshTestDir("pose");
  const Files f = Write(d);
  const PoseSeries a = LoadPoseSeries(f.truth, f.poses, f.crb);
  WriteText(d / "other.csv",
            "frame,t_ns,status,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg,n_beacons,rms_px\n"
            "0,100,fix,0,0,0,0,0,0,4,0.2\n1,200,lost,nan,nan,nan,nan,nan,nan,3,nan\n"
            "3,400,fix,0,0,0,0,0,3,3,0.2\n4,500,degraded,10,0,0,0,0,359.5,3,0.2\n6,700,fix,0,0,0,0,0,6,3,0.2\n");
  const PoseSeries b = LoadPoseSeries(f.truth, d / "other.csv", f.crb);
  EXPECT_EQ(CommonPosedFrames({&a, &b}, true), (std::set<long>{0, 3, 4}));
  EXPECT_EQ(CommonPosedFrames({&a, &b}, false), (std::set<long>{0}));
  const std::set<long> common = CommonPosedFrames({&a, &b}, true);
  const PoseSummary s = SummarizePoses(a, true, &common);
  EXPECT_EQ(s.frames, 7);
  EXPECT_EQ(s.fixes, 4);
  EXPECT_EQ(s.used, 3);
  EXPECT_NEAR(s.axes[0].mean, (1.0 + 4.0 + 5.0) / 3.0, 1e-12);
}

TEST(PoseErrors, WorksWithoutBound) {
  const Files f = Write(FreshTestDir("pose"));
  const PoseSummary s = SummarizePoses(LoadPoseSeries(f.truth, f.poses, ""), true);
  EXPECT_EQ(s.used, 5);
  EXPECT_EQ(s.axes[0].bound_rms, 0.0);
}

TEST(PoseErrors, RejectsUnknownStatusWithFileAndLine) {
  const std::string error = LoadError("frame,t_ns,status,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg,n_beacons,rms_px\n"
                                      "0,100,maybe,1,2,3,0,0,0,3,0.1\n");
  EXPECT_NE(error.find("poses.csv:2: unknown status 'maybe'"), std::string::npos) << error;
}

TEST(PoseErrors, RejectsMissingColumnAndRaggedRow) {
  const auto d = FreshTestDir("pose");
  Files f = Write(d, "frame,t_ns,status\n0,1,fix\n");
  EXPECT_THROW(LoadPoseSeries(f.truth, f.poses, f.crb), UserError);
  f = Write(d, "frame,t_ns,status,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg,n_beacons,rms_px\n0,1,fix\n");
  EXPECT_THROW(LoadPoseSeries(f.truth, f.poses, f.crb), UserError);
  EXPECT_THROW(LoadPoseSeries(d / "nope.csv", f.poses, f.crb), UserError);
}

}  // namespace
}  // namespace mfns::host
