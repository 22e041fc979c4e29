#include "host/report/compare.h"

#include <gtest/gtest.h>

#include <random>

#include "host/report/report_test_util.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

constexpr const char* kCrbHeader =
    "frame,n_visible,valid,sigma_x_mm,sigma_y_mm,sigma_z_mm,sigma_roll_deg,sigma_pitch_deg,sigma_yaw_deg\n";

// Estimates = truth + Gaussian errors of known sigma; the bound says that sigma: the statistics
// must come back (mean ~0, std ~ sigma, ratio ~1), and a frame with a bad status is left out.
TEST(Compare, RecoversKnownErrorStatistics) {
  const auto dir = FreshTestDir("compare");
  std::mt19937_64 rng(1);
  std::normal_distribution<double> n01(0.0, 1.0);
  const std::array<double, 6> sigma = {0.5, 0.7, 1.1, 0.01, 0.02, 0.03};
  std::string truth = "frame,t_ns,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg\n";
  std::string crb = "frame,t_ns,n_visible,n_x,n_y,n_z,valid,sigma_x_mm,sigma_y_mm,sigma_z_mm,sigma_roll_deg,sigma_pitch_deg,sigma_yaw_deg\n";
  std::string poses = "frame,t_ns,status,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg,n_beacons,rms_px\n";
  const int frames = 4000;
  for (int f = 0; f < frames; ++f) {
    const double yaw = std::remainder(f * 1.0, 360.0);
    truth += std::to_string(f) + ",0,0,0,0,0,0," + std::to_string(yaw) + "\n";
    crb += std::to_string(f) + ",0," + (f % 10 == 0 ? "2,1,1,0,0" : "4,2,1,1,1");
    for (double s : sigma) crb += "," + std::to_string(s);
    crb += "\n";
    if (f % 10 == 0) {
      poses += std::to_string(f) + ",0,lost,0,0,0,0,0,0,0,0\n";
      continue;
    }
    poses += std::to_string(f) + ",0,fix";
    for (int a = 0; a < 6; ++a) {
      double v = sigma[static_cast<std::size_t>(a)] * n01(rng);
      if (a == 5) v = std::remainder(yaw + v, 360.0);  // yaw wraps around +-180
      poses += "," + std::to_string(v);
    }
    poses += ",4,0.1\n";
  }
  WriteFileAtomic(dir / "truth.csv", truth);
  WriteFileAtomic(dir / "crb.csv", crb);
  WriteFileAtomic(dir / "poses.csv", poses);
  const PoseSummary r = ComparePoses(dir, dir / "poses.csv");
  EXPECT_EQ(r.frames, frames);
  EXPECT_EQ(r.lost, frames / 10);
  EXPECT_EQ(r.frames_3plus, frames - frames / 10);
  EXPECT_EQ(r.fixes_3plus, frames - frames / 10);
  EXPECT_EQ(r.used, frames - frames / 10);
  for (std::size_t a = 0; a < 6; ++a) {
    EXPECT_NEAR(r.axes[a].rms / r.axes[a].bound_rms, 1.0, 0.05) << kPoseAxes[a];
    EXPECT_NEAR(r.axes[a].mean, 0.0, 4.0 * sigma[a] / std::sqrt(3600.0)) << kPoseAxes[a];
  }
  EXPECT_NE(FormatCompare(r).find("rms/CRB"), std::string::npos);
  std::filesystem::remove_all(dir);
}

// The table of a designed run, character for character as `mfns-sim compare` printed it before
// it became a formatting of pose_errors (issue 15 item 5: output formats stay): fix frame 5 has
// no valid bound (left out of the statistics and of the >= 3 count), frame 3 is degraded,
// frame 6 has no pose, frame 4's yaw error wraps (359.5 -> -0.4 is +0.1).
TEST(Compare, TableOfADesignedRun) {
  const auto dir = FreshTestDir("compare");
  WriteFileAtomic(dir / "truth.csv", std::string("frame,t_ns,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg\n"
                                                 "0,100,0,0,0,0,0,0\n1,200,0,0,0,0,0,1\n2,300,0,0,0,0,0,2\n"
                                                 "3,400,0,0,0,0,0,3\n4,500,10,0,0,0,0,359.5\n5,600,0,0,0,0,0,5\n"
                                                 "6,700,0,0,0,0,0,6\n"));
  WriteFileAtomic(dir / "poses.csv", std::string("frame,t_ns,status,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg,n_beacons,rms_px\n"
                                                 "0,100,fix,1,-2,0.5,0.01,0,0.1,4,0.2\n1,200,fix,2,-2,0.5,0.01,0,1.1,3,0.1\n"
                                                 "2,300,fix,3,-2,0.5,0.01,0,2.1,5,0.3\n3,400,degraded,4,-2,0.5,0.01,0,3.1,3,1.5\n"
                                                 "4,500,fix,15,-2,0.5,0.01,0,-0.4,4,0.2\n5,600,fix,7,-2,0.5,0.01,0,5,2,0.2\n"));
  WriteFileAtomic(dir / "crb.csv",
                  std::string("frame,t_ns,n_visible,n_x,n_y,n_z,valid,sigma_x_mm,sigma_y_mm,sigma_z_mm,sigma_roll_deg,"
                              "sigma_pitch_deg,sigma_yaw_deg\n"
                              "0,100,4,1,2,1,1,0.3,0.1,0.1,0.01,0.01,0.01\n1,200,3,1,1,1,1,0.4,0.1,0.1,0.01,0.01,0.01\n"
                              "2,300,5,2,2,1,1,0.3,0.1,0.1,0.01,0.01,0.01\n3,400,3,0,2,1,1,0.4,0.1,0.1,0.01,0.01,0.01\n"
                              "4,500,4,1,1,2,1,0.3,0.1,0.1,0.01,0.01,0.01\n5,600,2,0,1,1,0,nan,nan,nan,nan,nan,nan\n"
                              "6,700,3,1,1,1,1,0.3,0.1,0.1,0.01,0.01,0.01\n"));
  EXPECT_EQ(FormatCompare(ComparePoses(dir, dir / "poses.csv")),
            "frame sets 7: >= 3 beacons visible 6, fix in 4 of those (66.7%); fix 5, degraded 1, lost 0, missing 1; "
            "compared 4\n"
            "axis          mean        std        rms   CRB rms   rms/CRB\n"
            "x_mm          2.7500     1.7078     3.1225    0.3279      9.52\n"
            "y_mm         -2.0000     0.0000     2.0000    0.1000     20.00\n"
            "z_mm          0.5000     0.0000     0.5000    0.1000      5.00\n"
            "roll_deg      0.0100     0.0000     0.0100    0.0100      1.00\n"
            "pitch_deg     0.0000     0.0000     0.0000    0.0100      0.00\n"
            "yaw_deg       0.1000     0.0000     0.1000    0.0100     10.00\n"
            "worst position error 5.408 mm, worst attitude error 0.1005 deg\n");
  std::filesystem::remove_all(dir);
}

TEST(Compare, MalformedInputsNameTheFileAndLine) {
  const auto dir = FreshTestDir("compare");
  WriteFileAtomic(dir / "truth.csv", std::string("frame,t_ns,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg\n0,0,0,0,0,0,0,0\n"));
  WriteFileAtomic(dir / "crb.csv", std::string("frame,n_visible,valid\n0,3\n"));
  WriteFileAtomic(dir / "poses.csv", std::string("frame,status\n0,fix\n"));
  try {
    ComparePoses(dir, dir / "poses.csv");
    FAIL() << "no error";
  } catch (const UserError& e) {
    EXPECT_EQ(std::string(e.what()), (dir / "crb.csv").string() + ":2: expected 3 cells (frame,n_visible,valid), got 2");
  }
  EXPECT_THROW(ComparePoses(dir / "nope", dir / "poses.csv"), UserError);
  std::filesystem::remove_all(dir);
}

// Issue 14, defect 10: an empty poses log (header only, as navd writes before its first frame
// set) or one that shares no frame with the truth is an error, not "0.000 mm"; all-lost poses
// give no error statistics.
TEST(Compare, EmptyOrDisjointPosesAreErrorsNotPerfectScores) {
  const auto dir = FreshTestDir("compare");
  WriteFileAtomic(dir / "truth.csv", std::string("frame,t_ns,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg\n0,0,0,0,0,0,0,0\n"));
  WriteFileAtomic(dir / "crb.csv", std::string(kCrbHeader) + "0,3,0,nan,nan,nan,nan,nan,nan\n");
  const std::string head = "frame,t_ns,status,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg,n_beacons,rms_px\n";
  const auto error = [&](const std::string& poses) {
    WriteFileAtomic(dir / "poses.csv", poses);
    try {
      ComparePoses(dir, dir / "poses.csv");
    } catch (const UserError& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  EXPECT_EQ(error(head), (dir / "poses.csv").string() + ": no poses (only a header); nothing to compare");
  EXPECT_EQ(error(head + "7,0,fix,0,0,0,0,0,0,3,0.1\n"),
            (dir / "poses.csv").string() + ": none of its 1 frames is in " + (dir / "truth.csv").string());
  EXPECT_EQ(error(head + "0,0,lost,0,0,0,0,0,0,0,0\n"), "(no error)");
  const std::string text = FormatCompare(ComparePoses(dir, dir / "poses.csv"));
  EXPECT_NE(text.find("no error statistics"), std::string::npos) << text;
  EXPECT_EQ(text.find("0.000 mm"), std::string::npos) << text;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace mfns::host
