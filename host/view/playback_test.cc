#include "host/view/playback.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "common/rotation/rotation.h"
#include "firmware/modules/publish/publishers.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

namespace fs = std::filesystem;

class PlaybackTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string tmpl = (fs::temp_directory_path() / "mfns-view-XXXXXX").string();
    ASSERT_NE(::mkdtemp(tmpl.data()), nullptr);
    dir_ = tmpl;
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path Write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name) << text;
    return dir_ / name;
  }
  std::string Error(const fs::path& p) {
    try {
      ReadPosesCsv(p);
    } catch (const UserError& e) {
      return e.what();
    }
    return "";
  }
  fs::path dir_;
};

// The rows mfns-navd's own log writer (fw::PoseLog) makes read back as the records it was given.
TEST_F(PlaybackTest, ThePoseLogsRowsReadBackAsItsRecords) {
  fw::PoseLog log;
  const fs::path path = dir_ / "poses.csv";
  ASSERT_EQ(log.Open(path.c_str()), fw::PublishStatus::kOk);
  std::vector<fw::PoseRecord> records(3);
  for (int i = 0; i < 3; ++i) {
    fw::PoseRecord& r = records[static_cast<std::size_t>(i)];
    r.frame_set = static_cast<std::uint32_t>(10 + i);
    r.t_capture_ns = std::uint64_t{1'000'000'000} + std::uint64_t{53'763'441} * static_cast<std::uint64_t>(i);
    r.status = i == 1 ? fw::NavStatus::kLost : fw::NavStatus::kDegraded;
    r.reason = i == 1 ? fw::NavReason::kAcquiring : fw::NavReason::kFewBeacons;
    r.num_beacons = i == 1 ? 0 : 3;
    r.r_w_wb = i == 1 ? Eigen::Vector3d::Constant(std::nan("")) : Eigen::Vector3d(0.5 * i, -1.25, 0.125);
    r.q_w_b = i == 1 ? Eigen::Quaterniond(std::nan(""), std::nan(""), std::nan(""), std::nan(""))
                     : Eigen::Quaterniond(ExpSO3(Eigen::Vector3d(0.2, -0.1, 0.7 * i)));
    r.residual_rms_px = 0.25f;
    ASSERT_EQ(log.Write(r), fw::PublishStatus::kOk);
  }
  ASSERT_EQ(log.Close(), fw::PublishStatus::kOk);
  const std::vector<ViewPose> poses = ReadPosesCsv(path);
  ASSERT_EQ(poses.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    const ViewPose& p = poses[i];
    EXPECT_EQ(p.frame_set, records[i].frame_set);
    EXPECT_EQ(p.t_ns, records[i].t_capture_ns);
    EXPECT_EQ(p.status, fw::ToString(records[i].status));
    EXPECT_EQ(p.reason, fw::ToString(records[i].reason));
    EXPECT_EQ(p.has_pose, i != 1);
    if (!p.has_pose) continue;
    EXPECT_LT((p.r_w_wb - records[i].r_w_wb).norm(), 1e-7);
    EXPECT_LT(LogSO3(p.C_w_b.transpose() * records[i].q_w_b.toRotationMatrix()).norm(), 1e-6);
  }
  EXPECT_DOUBLE_EQ(PlaybackDelayS(poses, 1, 1.0), 0.053763441);
  EXPECT_DOUBLE_EQ(PlaybackDelayS(poses, 1, 10.0), 0.0053763441);
}

TEST_F(PlaybackTest, BadFilesAreRefusedInOneLineNamingTheFileAndField) {
  const std::string header = "frame,t_ns,status,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg,n_beacons,rms_px\n";
  std::string e = Error(Write("a.csv", header + "0,0,fixed,0,0,0,0,0,0,3,0.1\n"));
  EXPECT_NE(e.find("a.csv:2: column 'status'"), std::string::npos) << e;
  e = Error(Write("b.csv", header + "-1,0,fix,0,0,0,0,0,0,3,0.1\n"));
  EXPECT_NE(e.find("b.csv:2: column 'frame'"), std::string::npos) << e;
  e = Error(Write("c.csv", header + "0,1e300,fix,0,0,0,0,0,0,3,0.1\n"));
  EXPECT_NE(e.find("column 't_ns'"), std::string::npos) << e;
  e = Error(Write("d.csv", "frame,t_ns,status\n0,0,fix\n"));
  EXPECT_NE(e.find("no column 'x_mm'"), std::string::npos) << e;
  e = Error(Write("e.csv", header));
  EXPECT_NE(e.find("e.csv: no rows"), std::string::npos) << e;
  e = Error(dir_ / "missing.csv");
  EXPECT_NE(e.find("missing.csv"), std::string::npos) << e;
  for (const std::string& m : {Error(dir_ / "a.csv"), Error(dir_ / "d.csv")}) EXPECT_EQ(m.find('\n'), std::string::npos);
}

TEST_F(PlaybackTest, AGapInTheLogDoesNotStallThePlayback) {
  std::vector<ViewPose> poses(2);
  poses[1].t_ns = 30'000'000'000ULL;  // 30 s later
  EXPECT_DOUBLE_EQ(PlaybackDelayS(poses, 1, 1.0), 1.0);
  poses[1].t_ns = 0;
  poses[0].t_ns = 5;  // backwards
  EXPECT_DOUBLE_EQ(PlaybackDelayS(poses, 1, 1.0), 0.0);
}

}  // namespace
}  // namespace mfns::host
