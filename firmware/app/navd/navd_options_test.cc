#include "firmware/app/navd/navd_options.h"

#include <gtest/gtest.h>

#include <cmath>

#include <string>
#include <vector>

#include "common/rotation/rotation.h"

namespace mfns::fw {
namespace {

struct Args {
  std::vector<std::string> s;
  std::vector<char*> p;
  explicit Args(std::vector<std::string> a) : s(std::move(a)) {
    s.insert(s.begin(), "mfns-navd");
    for (auto& x : s) p.push_back(x.data());
    p.push_back(nullptr);
  }
  int argc() const { return static_cast<int>(s.size()); }
};

OptionsStatus Parse(std::vector<std::string> a, NavdOptions* o, std::string* why) {
  Args args(std::move(a));
  char buf[256] = {};
  const OptionsStatus s = ParseNavdOptions(args.argc(), args.p.data(), o, buf, sizeof(buf));
  *why = buf;
  return s;
}

TEST(NavdOptions, TheDesignCommandLine) {
  NavdOptions o;
  std::string why;
  ASSERT_EQ(Parse({"--params", "/var/lib/mfns/params", "--source", "replay:/data/run1", "--output", "udp://127.0.0.1:14550",
                   "--log", "poses.csv", "--frames", "360"},
                  &o, &why),
            OptionsStatus::kOk)
      << why;
  EXPECT_STREQ(o.params.data(), "/var/lib/mfns/params");
  EXPECT_EQ(o.source, SourceKind::kReplay);
  EXPECT_STREQ(o.replay_dir.data(), "/data/run1");
  ASSERT_EQ(o.num_outputs, 1);
  EXPECT_STREQ(o.outputs[0].data(), "udp://127.0.0.1:14550");
  EXPECT_STREQ(o.log.data(), "poses.csv");
  EXPECT_EQ(o.frames, 360);
  // Rate-derived defaults: 18.6 Hz -> 53.8 ms period.
  EXPECT_EQ(o.timeout_ms, 161);
  EXPECT_NEAR(o.deadline_ms, 53.763, 1e-3);
  EXPECT_EQ(o.health_every, 19);
  EXPECT_TRUE(o.windowed_detection);  // issue 20 item 1: on unless turned off
  NavdOptions off;
  ASSERT_EQ(Parse({"--params", "p", "--source", "replay:d", "--no-windowed-detection"}, &off, &why), OptionsStatus::kOk)
      << why;
  EXPECT_FALSE(off.windowed_detection);
  EXPECT_FALSE(o.three_beacon_fixes);  // session 28: three-beacon tracks unverified unless asked
  NavdOptions lab;
  ASSERT_EQ(Parse({"--params", "p", "--source", "replay:d", "--three-beacon-fixes"}, &lab, &why), OptionsStatus::kOk)
      << why;
  EXPECT_TRUE(lab.three_beacon_fixes);
}

// --initial-pose is in the poses CSV's terms: the pose it gives, logged, reads back the same
// (the CSV's angles are the Euler angles of C_b_w, publishers.cc).
TEST(NavdOptions, InitialPoseInThePosesCsvTerms) {
  NavdOptions o;
  std::string why;
  BodyPose pose;
  ASSERT_EQ(Parse({"--params", "p.bin", "--source", "replay:d"}, &o, &why), OptionsStatus::kOk) << why;
  EXPECT_FALSE(InitialPoseOf(o, &pose));
  ASSERT_EQ(Parse({"--params", "p.bin", "--source", "replay:d", "--initial-pose", "12.5,-30,4,1.5,-2,120",
                   "--initial-sigma", "5,0.5"},
                  &o, &why),
            OptionsStatus::kOk)
      << why;
  ASSERT_TRUE(InitialPoseOf(o, &pose));
  EXPECT_NEAR(pose.r_w_wb.x(), 0.0125, 1e-12);
  EXPECT_NEAR(pose.r_w_wb.y(), -0.030, 1e-12);
  EXPECT_NEAR(pose.r_w_wb.z(), 0.004, 1e-12);
  const EulerAngles e = MatrixToEuler(pose.C_w_b.transpose());
  EXPECT_NEAR(RadToDeg(e.phi), 1.5, 1e-9);
  EXPECT_NEAR(RadToDeg(e.theta), -2.0, 1e-9);
  EXPECT_NEAR(RadToDeg(e.psi), 120.0, 1e-9);
  // Yaw alone: C_w_b turns body x towards world y.
  ASSERT_EQ(Parse({"--params", "p.bin", "--source", "replay:d", "--initial-pose", "0,0,0,0,0,90"}, &o, &why),
            OptionsStatus::kOk);
  ASSERT_TRUE(InitialPoseOf(o, &pose));
  EXPECT_NEAR((pose.C_w_b * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm(), 0.0, 1e-12);
  EXPECT_DOUBLE_EQ(o.initial_sigma_mm, 10.0);
  EXPECT_DOUBLE_EQ(o.initial_sigma_deg, 1.0);
  for (const char* bad : {"1,2,3,4,5", "1,2,3,4,5,6,7", "1,2,3,4,5,x", "1,2,3,4,5,nan", "", "1,,3,4,5,6"}) {
    EXPECT_EQ(Parse({"--params", "p.bin", "--source", "replay:d", "--initial-pose", bad}, &o, &why),
              OptionsStatus::kError)
        << bad;
    EXPECT_NE(why.find("--initial-pose"), std::string::npos) << why;
  }
  for (const char* bad : {"5", "-1,1", "5,200", "a,b"}) {
    EXPECT_EQ(Parse({"--params", "p.bin", "--source", "replay:d", "--initial-sigma", bad}, &o, &why),
              OptionsStatus::kError)
        << bad;
    EXPECT_NE(why.find("--initial-sigma"), std::string::npos) << why;
  }
}

TEST(NavdOptions, V4l2DevicesAndTrigger) {
  NavdOptions o;
  std::string why;
  ASSERT_EQ(Parse({"--params", "p.bin", "--source", "v4l2", "--device", "x=/dev/video2", "--device", "z=/dev/video0",
                   "--trigger", "gpiochip1:17", "--y16", "--rate-hz", "30", "--buffers", "6"},
                  &o, &why),
            OptionsStatus::kOk)
      << why;
  EXPECT_EQ(o.source, SourceKind::kV4l2);
  ASSERT_EQ(o.num_devices, 2);
  EXPECT_STREQ(o.device_camera[1].data(), "z");
  EXPECT_STREQ(o.device_path[0].data(), "/dev/video2");
  EXPECT_STREQ(o.trigger_chip.data(), "gpiochip1");
  EXPECT_EQ(o.trigger_line, 17);
  EXPECT_TRUE(o.y16);
  EXPECT_EQ(o.buffers, 6);
  EXPECT_EQ(o.timeout_ms, 100);
}

// Issue 17: several outputs at once, any mix, up to limits::kMaxOutputs; the MAVLink ids and axes.
TEST(NavdOptions, OutputsAndMavlink) {
  NavdOptions o;
  std::string why;
  ASSERT_EQ(Parse({"--params", "p", "--source", "v4l2"}, &o, &why), OptionsStatus::kOk) << why;
  EXPECT_EQ(o.num_outputs, 0);
  EXPECT_EQ(o.mavlink.system_id, 1);
  EXPECT_EQ(o.mavlink.component_id, 197);  // MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY
  EXPECT_EQ(o.mavlink.axes, MavlinkAxes::kFrd);
  ASSERT_EQ(Parse({"--params", "p", "--source", "v4l2", "--output", "udp://10.0.0.1:5600", "--output",
                   "mavlink+udp://127.0.0.1:14540", "--mavlink-sysid", "2", "--mavlink-compid", "191",
                   "--mavlink-frame", "flu"},
                  &o, &why),
            OptionsStatus::kOk)
      << why;
  ASSERT_EQ(o.num_outputs, 2);
  EXPECT_STREQ(o.outputs[0].data(), "udp://10.0.0.1:5600");
  EXPECT_STREQ(o.outputs[1].data(), "mavlink+udp://127.0.0.1:14540");
  EXPECT_EQ(o.mavlink.system_id, 2);
  EXPECT_EQ(o.mavlink.component_id, 191);
  EXPECT_EQ(o.mavlink.axes, MavlinkAxes::kFlu);
  std::vector<std::string> five = {"--params", "p", "--source", "v4l2"};
  for (int i = 0; i <= limits::kMaxOutputs; ++i) {
    five.push_back("--output");
    five.push_back("mavlink+udp://127.0.0.1:" + std::to_string(14540 + i));
  }
  EXPECT_EQ(Parse(five, &o, &why), OptionsStatus::kError);
  EXPECT_EQ(why, "--output: at most 4 outputs, 'mavlink+udp://127.0.0.1:14544' is one more");
  // A MAVLink setting without a MAVLink output would be ignored: refused, naming the option.
  EXPECT_EQ(Parse({"--params", "p", "--source", "v4l2", "--output", "udp://10.0.0.1:5600", "--mavlink-frame", "flu"},
                  &o, &why),
            OptionsStatus::kError);
  EXPECT_EQ(why, "--mavlink-frame: no --output mavlink+udp://HOST:PORT to apply it to");
  EXPECT_EQ(Parse({"--params", "p", "--source", "v4l2", "--mavlink-sysid", "0"}, &o, &why), OptionsStatus::kError);
  EXPECT_EQ(why, "--mavlink-sysid: expected 1..255, got '0'");
  EXPECT_EQ(Parse({"--params", "p", "--source", "v4l2", "--mavlink-compid", "256"}, &o, &why), OptionsStatus::kError);
  EXPECT_EQ(why, "--mavlink-compid: expected 1..255, got '256'");
  EXPECT_EQ(Parse({"--params", "p", "--source", "v4l2", "--mavlink-frame", "ned"}, &o, &why), OptionsStatus::kError);
  EXPECT_EQ(why, "--mavlink-frame: expected frd or flu, got 'ned'");
}

TEST(NavdOptions, OneLineReasons) {
  NavdOptions o;
  std::string why;
  EXPECT_EQ(Parse({"--source", "v4l2"}, &o, &why), OptionsStatus::kError);
  EXPECT_EQ(why, "--params FILE|DIR is required");
  EXPECT_EQ(Parse({"--params", "p"}, &o, &why), OptionsStatus::kError);
  EXPECT_EQ(why, "--source v4l2|replay:DIR is required");
  EXPECT_EQ(Parse({"--params", "p", "--source", "usb"}, &o, &why), OptionsStatus::kError);
  EXPECT_EQ(why, "--source: expected v4l2 or replay:DIR, got 'usb'");
  EXPECT_EQ(Parse({"--params", "p", "--source", "v4l2", "--frames", "-3"}, &o, &why), OptionsStatus::kError);
  EXPECT_EQ(why, "--frames: expected a positive count, got '-3'");
  EXPECT_EQ(Parse({"--params", "p", "--source", "v4l2", "--output", "tcp://x:1"}, &o, &why), OptionsStatus::kError);
  EXPECT_EQ(why, "--output: expected udp://HOST:PORT or mavlink+udp://HOST:PORT, got 'tcp://x:1'");
  EXPECT_EQ(Parse({"--params", "p", "--source", "v4l2", "--output", "mavlink://x:1"}, &o, &why), OptionsStatus::kError);
  EXPECT_EQ(why, "--output: expected udp://HOST:PORT or mavlink+udp://HOST:PORT, got 'mavlink://x:1'");
  EXPECT_EQ(Parse({"--params", "p", "--source", "v4l2", "--trigger", "gpiochip0"}, &o, &why), OptionsStatus::kError);
  EXPECT_EQ(Parse({"--params", "p", "--source", "v4l2", "--bogus"}, &o, &why), OptionsStatus::kError);
  EXPECT_EQ(why, "unknown option or missing value: '--bogus' (see --help)");
  EXPECT_EQ(Parse({"--params", "p", "--source", "v4l2", "stray"}, &o, &why), OptionsStatus::kError);
  EXPECT_EQ(why, "unexpected argument 'stray' (see --help)");
  EXPECT_EQ(Parse({"--params", std::string(300, 'a'), "--source", "v4l2"}, &o, &why), OptionsStatus::kError);
  EXPECT_EQ(Parse({"--help"}, &o, &why), OptionsStatus::kHelp);
}

}  // namespace
}  // namespace mfns::fw
