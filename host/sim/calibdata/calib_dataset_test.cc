#include "host/sim/calibdata/calib_dataset.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <map>
#include <opencv2/calib3d.hpp>

#include "common/rotation/rotation.h"
#include "host/rigio/rig_yaml.h"
#include "host/core/image.h"
#include "host/core/target.h"
#include "host/util/csv_table.h"

namespace mfns::host {
namespace {

// The writer's headers, checked by the reader; the tests read cells by these positions.
const CsvOptions kCornersCsv{.trim = false, .columns = "camera,image,corner,u_px,v_px", .header_optional = false};
const CsvOptions kImagesCsv{.trim = false, .columns = "camera,image,kind,main_deg,aux_deg", .header_optional = false};

std::filesystem::path TempDir() {
  std::string tmpl = (std::filesystem::temp_directory_path() / "mfns-calibdata-XXXXXX").string();
  EXPECT_NE(::mkdtemp(tmpl.data()), nullptr);
  return tmpl;
}

Scenario SmallSession(bool noise) {
  Scenario s = LoadPreset("paper-calibration");
  s.calibration.turntable_images = 3;
  s.calibration.free_images = 2;
  s.errors.pixel_noise = noise;
  return s;
}

// Issue 14, defect 10: a rig without beacons (a calibration result) is enough to simulate a
// calibration session; its truth-rig.yaml has no beacons either.
TEST(CalibDataset, ARigWithoutBeaconsIsEnough) {
  const auto dir = TempDir();
  CalibDatasetOptions opt;
  opt.out_dir = dir;
  opt.progress = false;
  Scenario s = ParseScenarioYaml(PresetYaml("paper-calibration") + "beacons_mm: []\n", "c.yaml", ".");
  s.calibration.turntable_images = 1;
  s.calibration.free_images = 1;
  const CalibDatasetSummary sum = WriteCalibDataset(s, "", opt);
  EXPECT_EQ(sum.images, 6);
  EXPECT_EQ(ReadRigYaml(dir / "truth-rig.yaml").num_beacons, 0);
  std::filesystem::remove_all(dir);
}

// A camera the turntable cannot turn towards the target (one looking along -z_b with the paper's
// mount; seen on a user rig) gets a warning naming it: its turntable images never show the
// whole target, so mfns-calib rig would refuse it. The paper rig's cameras get none.
TEST(CalibDataset, ACameraTheTurntableCannotFaceToTheTargetIsNamed) {
  const auto dir = TempDir();
  CalibDatasetOptions opt;
  opt.out_dir = dir;
  opt.progress = false;
  Scenario s = SmallSession(false);
  s.calibration.free_images = 1;
  const CalibDatasetSummary good = WriteCalibDataset(s, "", opt);
  ASSERT_EQ(good.turntable_complete.size(), static_cast<std::size_t>(s.rig.num_cameras));
  for (int k = 0; k < s.rig.num_cameras; ++k) EXPECT_EQ(good.turntable_images[static_cast<std::size_t>(k)], 3);
  EXPECT_TRUE(TurntableWarnings(s, good).empty());
  RigCamera& cam = s.rig.cameras[2];
  cam.C_k_b << 1, 0, 0, 0, -1, 0, 0, 0, -1;  // along -z_b
  const CalibDatasetSummary bad = WriteCalibDataset(s, "", opt);
  EXPECT_EQ(bad.turntable_complete[2], 0);
  EXPECT_GT(bad.turntable_complete[0], 0);
  const std::vector<std::string> w = TurntableWarnings(s, bad);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0].rfind("camera " + std::string(cam.name.data()) + ": none of its 3 turntable images", 0), 0u) << w[0];
  std::filesystem::remove_all(dir);
}

// Every turntable image's corners follow from the truth files alone: the turntable pose from
// the true angles, the rig from truth-rig.yaml, the corner from the target definition.
TEST(CalibDataset, TruthChainIsConsistent) {
  const auto dir = TempDir();
  CalibDatasetOptions opt;
  opt.out_dir = dir;
  opt.progress = false;
  const Scenario s = SmallSession(true);
  const CalibDatasetSummary sum = WriteCalibDataset(s, "", opt);
  EXPECT_EQ(sum.images, 15);
  EXPECT_EQ(sum.complete, 15) << "every image should show the whole board";

  const Rig rig = ReadRigYaml(dir / "truth-rig.yaml");
  const YAML::Node truth = YAML::LoadFile((dir / "truth.yaml").string());
  Turntable tt;
  const auto m9 = [](const YAML::Node& n) {
    Eigen::Matrix3d M;
    for (int i = 0; i < 9; ++i) M(i / 3, i % 3) = n[i].as<double>();
    return M;
  };
  const auto v3 = [](const YAML::Node& n) { return Eigen::Vector3d(n[0].as<double>(), n[1].as<double>(), n[2].as<double>()) * 1e-3; };
  tt.C_w_t = m9(truth["C_w_t"]);
  tt.r_w_wt = v3(truth["r_w_wt_mm"]);
  tt.C_p_b = m9(truth["C_p_b"]);
  tt.r_p_pb = v3(truth["r_p_pb_mm"]);
  CheckerboardSpec spec;
  spec.cols = 9;
  spec.rows = 6;
  spec.square_m = 0.020;
  const CalibrationTarget target = CalibrationTarget::Checkerboard(spec);

  std::map<std::string, std::pair<double, double>> angles;  // "cam/img" -> true (main, aux)
  for (const auto& im : truth["images"])
    if (im["kind"].as<std::string>() == "turntable")
      angles[im["camera"].as<std::string>() + "/" + im["image"].as<std::string>()] = {
          DegToRad(im["main_true_deg"].as<double>()), DegToRad(im["aux_true_deg"].as<double>())};
  EXPECT_EQ(angles.size(), 9u);

  int checked = 0;
  const CsvTable corners = CsvTable::Read(dir / "corners.csv", kCornersCsv);
  for (std::size_t r = 0; r < corners.size(); ++r) {
    const std::string& camera = corners.Cell(r, 0);
    const auto it = angles.find(camera + "/" + corners.Cell(r, 1));
    if (it == angles.end()) continue;
    int k = 0;
    while (camera != rig.cameras[static_cast<std::size_t>(k)].name.data()) ++k;
    const BodyPose body = TurntablePose(tt, it->second.first, it->second.second);
    Eigen::Vector2d uv;
    ASSERT_EQ(ProjectBeacon(rig.cameras[static_cast<std::size_t>(k)], body,
                            target.corners()[static_cast<std::size_t>(corners.Number(r, 2))].P_w, &uv),
              ProjectStatus::kOk);
    EXPECT_NEAR(uv.x(), corners.Number(r, 3), 1e-6);
    EXPECT_NEAR(uv.y(), corners.Number(r, 4), 1e-6);
    ++checked;
  }
  EXPECT_EQ(checked, 9 * 54);

  // Commanded angles differ from the true ones by the turntable's error (8 arcsec).
  const CsvTable images = CsvTable::Read(dir / "images.csv", kImagesCsv);
  for (std::size_t r = 0; r < images.size(); ++r) {
    if (images.Cell(r, 2) != "turntable") continue;
    const auto& t = angles[images.Cell(r, 0) + "/" + images.Cell(r, 1)];
    EXPECT_LT(std::abs(DegToRad(images.Number(r, 3)) - t.first), DegToRad(60.0 / 3600.0));
    EXPECT_LT(std::abs(DegToRad(images.Number(r, 4)) - t.second), DegToRad(60.0 / 3600.0));
  }
  std::filesystem::remove_all(dir);
}

// An independent detector finds the board where corners.csv says it is.
TEST(CalibDataset, OpenCvFindsTheCornersWhereTheTruthIs) {
  const auto dir = TempDir();
  CalibDatasetOptions opt;
  opt.out_dir = dir;
  opt.progress = false;
  WriteCalibDataset(SmallSession(true), "", opt);
  std::map<std::string, std::vector<cv::Point2d>> truth;
  const CsvTable corners = CsvTable::Read(dir / "corners.csv", kCornersCsv);
  for (std::size_t r = 0; r < corners.size(); ++r)
    truth[corners.Cell(r, 0) + "/" + corners.Cell(r, 1)].emplace_back(corners.Number(r, 3), corners.Number(r, 4));
  // findChessboardCornersSB takes seconds per image: one turntable and one free view per camera.
  int images = 0;
  for (const auto& [key, pts] : truth) {
    if (key.substr(2) != "000" && key.substr(2) != "003") continue;
    const cv::Mat img = ReadPgm((dir / "images" / (key + ".pgm")).string());
    std::vector<cv::Point2f> found;
    ASSERT_TRUE(cv::findChessboardCornersSB(img, cv::Size(9, 6), found, cv::CALIB_CB_ACCURACY)) << key;
    ASSERT_EQ(found.size(), 54u);
    // OpenCV may start from either end of the symmetric board: compare as sets.
    double worst = 0;
    for (const cv::Point2d& t : pts) {
      double best = 1e9;
      for (const cv::Point2f& f : found) best = std::min(best, std::hypot(static_cast<double>(f.x) - t.x, static_cast<double>(f.y) - t.y));
      worst = std::max(worst, best);
    }
    EXPECT_LT(worst, 0.25) << key;
    ++images;
  }
  EXPECT_EQ(images, 6);
  std::filesystem::remove_all(dir);
}

TEST(CalibDataset, RefusesAScenarioWithoutTarget) {
  CalibDatasetOptions opt;
  opt.out_dir = TempDir();
  EXPECT_THROW(WriteCalibDataset(LoadPreset("paper-turntable"), "", opt), UserError);
  std::filesystem::remove_all(opt.out_dir);
}

}  // namespace
}  // namespace mfns::host
