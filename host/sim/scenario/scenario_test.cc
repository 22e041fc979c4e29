#include "host/sim/scenario/scenario.h"

#include <gtest/gtest.h>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "host/sim/scenario/scenario_test_util.h"

namespace mfns::host {
namespace {

TEST(Scenario, PresetsParse) {
  for (const std::string& name : PresetNames()) {
    const Scenario s = LoadPreset(name);
    EXPECT_EQ(s.name, name);
    EXPECT_EQ(ValidateRig(s.rig), RigStatus::kOk) << name;
    EXPECT_GT(s.frames, 0);
  }
  EXPECT_THROW(PresetYaml("no-such"), UserError);
}

TEST(Scenario, PaperTurntableIsAYawSweepAboutTheOrigin) {
  const Scenario s = LoadPreset("paper-turntable");
  EXPECT_EQ(s.frames, 360);
  const auto frames = SimulateTrajectory(s);
  ASSERT_EQ(frames.size(), 360u);
  for (const FrameTruth& f : frames) {
    EXPECT_LT(f.pose.r_w_wb.norm(), 1e-15);
    const EulerAngles e = MatrixToEuler(f.pose.C_w_b.transpose());
    EXPECT_NEAR(e.phi, 0.0, 1e-12);
    EXPECT_NEAR(e.theta, 0.0, 1e-12);
    EXPECT_NEAR(std::remainder(e.psi - DegToRad(f.frame), 2 * kPi), 0.0, 1e-12);  // truth (0, 0, psi_t)
    EXPECT_EQ(f.main_true, f.main_cmd);  // turntable angle error off in this preset
  }
  EXPECT_EQ(frames[1].t_ns - frames[0].t_ns, 53763441);  // 18.6 Hz
}

TEST(Scenario, TurntableAngleErrorIsSeededAndSized) {
  Scenario s = LoadPreset("paper-turntable");
  s.errors.turntable_angle = true;
  s.frames = 4000;
  const auto a = SimulateTrajectory(s), b = SimulateTrajectory(s);
  double sum2 = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].main_true, b[i].main_true);
    sum2 += std::pow(a[i].main_true - a[i].main_cmd, 2);
  }
  EXPECT_NEAR(std::sqrt(sum2 / a.size()) / (DegToRad(8.0 / 3600.0)), 1.0, 0.05);
  s.seed = 2;
  EXPECT_NE(SimulateTrajectory(s)[5].main_true, a[5].main_true);
}

TEST(Scenario, TurntableKinematics) {
  Turntable tt;
  tt.r_p_pb = Eigen::Vector3d(0.1, 0, 0);
  // Main axis +90 deg turns the platform's x axis onto the turntable's y axis (active).
  const BodyPose p = TurntablePose(tt, DegToRad(90), 0.0);
  EXPECT_TRUE(p.r_w_wb.isApprox(Eigen::Vector3d(0, 0.1, 0), 1e-12));
  const BodyPose q = TurntablePose(tt, 0.0, DegToRad(90));  // aux about x: x stays
  EXPECT_TRUE(q.r_w_wb.isApprox(Eigen::Vector3d(0.1, 0, 0), 1e-12));
  EXPECT_TRUE((q.C_w_b * Eigen::Vector3d::UnitY()).isApprox(Eigen::Vector3d::UnitZ(), 1e-12));
  // The outer aux axis tilts the inner main axis: main 90 then aux -90 turns the body's -x
  // axis (camera X's view) up.
  const BodyPose up = TurntablePose(Turntable{}, DegToRad(90), DegToRad(-90));
  EXPECT_TRUE((up.C_w_b * -Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitZ(), 1e-12));
}

TEST(Scenario, BelievedRigPerturbsOnlyWhatIsEnabled) {
  Scenario s = LoadPreset("free-flight");
  const Rig same = BelievedRig(s);  // only pixel noise on: belief == truth
  for (std::size_t i = 0; i < static_cast<std::size_t>(s.rig.num_beacons); ++i)
    EXPECT_EQ(same.beacons_w[i], s.rig.beacons_w[i]);
  EXPECT_EQ(same.cameras[0].C_k_b, s.rig.cameras[0].C_k_b);
  EXPECT_GT(s.rig.beacon_sigma, 0.0);  // the preset quotes a survey accuracy...
  EXPECT_EQ(same.beacon_sigma, 0.0);   // ...but the believed map is the true one

  s.errors.beacon_map = true;
  s.errors.beacon_sigma = 0.4e-3;
  const Rig b = BelievedRig(s);
  double sum2 = 0;
  for (std::size_t i = 0; i < static_cast<std::size_t>(s.rig.num_beacons); ++i)
    sum2 += (b.beacons_w[i] - s.rig.beacons_w[i]).squaredNorm();
  EXPECT_NEAR(std::sqrt(sum2 / (3.0 * s.rig.num_beacons)) / 0.4e-3, 1.0, 0.2);
  EXPECT_EQ(b.cameras[1].r_b_bk, s.rig.cameras[1].r_b_bk);
  EXPECT_EQ(b.beacon_sigma, 0.4e-3);

  s.errors.extrinsic_rotation = true;
  const Rig r = BelievedRig(s);
  const double angle = LogSO3(r.cameras[2].C_k_b * s.rig.cameras[2].C_k_b.transpose()).norm();
  EXPECT_GT(angle, 0.0);
  EXPECT_LT(angle, DegToRad(0.6));  // 0.1 deg per axis: beyond 0.6 deg is a > 5 sigma event
}

TEST(Scenario, FreeFlightStaysInsideTheModule) {
  const Scenario s = LoadPreset("free-flight");
  for (const FrameTruth& f : SimulateTrajectory(s)) EXPECT_LT(f.pose.r_w_wb.cwiseAbs().maxCoeff(), 0.6);
}


TEST(Scenario, ErrorsNameTheField) {
  EXPECT_EQ(ScenarioErrorOf("frame_rate: 10\n"), "s.yaml:1: unknown field 'frame_rate'");
  EXPECT_EQ(ScenarioErrorOf("frames: 0\n"), "s.yaml:1: frames: must be 1..1000000");
  EXPECT_EQ(ScenarioErrorOf("trajectory: {kind: spin}\n"), "s.yaml:1: trajectory.kind: expected static, turntable, free-flight or wander, got 'spin'");
  EXPECT_EQ(ScenarioErrorOf("errors:\n  beacon_map: {sigma_mm: -1}\n"), "s.yaml:2: errors.beacon_map.sigma_mm: must not be negative");
  EXPECT_EQ(ScenarioErrorOf("clutter: {stop_camera: w}\n"), "s.yaml:1: clutter.stop_camera: no camera named 'w' in the rig");
  EXPECT_EQ(ScenarioErrorOf("rig: missing.yaml\n"), "s.yaml:1: rig: ./missing.yaml: no such file");
}

// Issue 14, defect 10: a key that is a list, or a t0_ns that is not an integer, is named with
// the file and the line (yaml-cpp's "bad conversion", or a silent default, before).
TEST(Scenario, WrongNodeTypesNameTheField) {
  EXPECT_EQ(ScenarioErrorOf("? [a, b]\n: 1\n"), "s.yaml:1: a key must be a name, not a list or a map");
  EXPECT_EQ(ScenarioErrorOf("t0_ns: soon\n"), "s.yaml:1: t0_ns: expected a non-negative integer");
}

// Issue 14, defect 10: a calibration session (target:) needs no beacons, so its rig may be a
// calibration result without a map; any other scenario still needs them.
TEST(Scenario, CalibrationScenariosNeedNoBeacons) {
  const std::string text = PresetYaml("paper-calibration") + "beacons_mm: []\n";
  const Scenario s = ParseScenarioYaml(text, "c.yaml", ".");
  EXPECT_EQ(s.rig.num_beacons, 0);
  EXPECT_TRUE(s.calibration.present);
  std::string turntable = PresetYaml("paper-turntable") + "beacons_mm: []\n";
  try {
    ParseScenarioYaml(turntable, "t.yaml", ".");
    ADD_FAILURE() << "a turntable sweep without beacons was accepted";
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("t.yaml:1: the scenario has no beacons"), std::string::npos) << e.what();
  }
}

// Found by scenario_yaml_fuzz (issue 14 item 2): a scenario's own beacons_mm passed unchecked (a
// beacon 5.9 km out made a rig that ValidateRig refuses); now checked like a rig file's.
TEST(Scenario, OwnBeaconsAreCheckedLikeARigFile) {
  EXPECT_EQ(ScenarioErrorOf("beacons_mm: [[0, 0, 1000], [-5910000, 0, 0], [0, 100, 1000]]\n"),
            "s.yaml:1: beacons_mm[1]: beacon position outside +-1e6 mm (1 km) of the world origin");
  EXPECT_EQ(ScenarioErrorOf("beacons_mm: [[0, 0, 1000], [0, 0, 1000.5], [0, 100, 1000]]\n").rfind("s.yaml:1: beacons_mm[1]: same position as beacons_mm[0]", 0), 0u);
}

}  // namespace
}  // namespace mfns::host
