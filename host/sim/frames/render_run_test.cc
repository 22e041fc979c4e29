#include "host/sim/frames/render_run.h"

#include <gtest/gtest.h>

#include <fstream>

#include "host/rigio/rig_yaml.h"
#include "host/core/image.h"
#include "host/util/atomic_file.h"
#include "host/util/csv_table.h"

namespace mfns::host {
namespace {

std::filesystem::path TempDir() {
  std::string tmpl = (std::filesystem::temp_directory_path() / "mfns-render-XXXXXX").string();
  EXPECT_NE(::mkdtemp(tmpl.data()), nullptr);
  return tmpl;
}

Scenario Small(int frames, bool noise) {
  Scenario s = LoadPreset("paper-turntable");
  s.frames = frames;
  s.trajectory.main_step = 30.0 * 3.14159265358979 / 180.0;
  s.errors.pixel_noise = noise;
  return s;
}

TEST(RenderRun, WritesTheDesignLayoutAndTruth) {
  const auto dir = TempDir();
  RenderOptions opt;
  opt.out_dir = dir;
  opt.progress = false;
  const Scenario s = Small(12, true);
  const RenderSummary sum = RenderScenario(s, "name: test\n", opt);
  EXPECT_EQ(sum.frames, 12);
  for (const char* cam : {"x", "y", "z"})
    for (int i = 0; i < 12; ++i) {
      char name[32];
      std::snprintf(name, sizeof(name), "%06d.pgm", i);
      const cv::Mat img = ReadPgm((dir / "frames" / cam / name).string());
      EXPECT_EQ(img.cols, 1280);
      EXPECT_EQ(img.rows, 1024);
      EXPECT_EQ(img.type(), CV_8UC1);
    }
  const CsvTable truth = CsvTable::Read(dir / "truth.csv");
  ASSERT_EQ(truth.size(), 12u);
  EXPECT_EQ(truth.header()[0], "frame");
  EXPECT_EQ(truth.header().size(), 8u);
  EXPECT_NEAR(truth.Number(3, truth.Column("yaw_deg")), 90.0, 1e-6);  // frame 3 at 30 deg steps: yaw 90
  const CsvTable crb = CsvTable::Read(dir / "crb.csv");
  ASSERT_EQ(crb.size(), 12u);
  // rig.yaml is the truth (exact map: no beacon_sigma, whatever the scenario's rig quotes).
  EXPECT_GT(s.rig.beacon_sigma, 0.0);
  EXPECT_EQ(ReadRigYaml(dir / "rig.yaml").beacon_sigma, 0.0);
  EXPECT_TRUE(std::filesystem::exists(dir / "believed-rig.yaml"));
  EXPECT_TRUE(std::filesystem::exists(dir / "turntable.csv"));
  EXPECT_TRUE(std::filesystem::exists(dir / "turntable-survey.yaml"));  // the surveyed placement
  // blobs.csv lists exactly the beacons crb.csv counts as visible.
  const CsvTable blobs = CsvTable::Read(dir / "blobs.csv");
  std::vector<int> per_frame(12, 0);
  for (std::size_t r = 0; r < blobs.size(); ++r) ++per_frame[static_cast<std::size_t>(blobs.Number(r, blobs.Column("frame")))];
  for (std::size_t i = 0; i < 12; ++i) EXPECT_EQ(per_frame[i], static_cast<int>(crb.Number(i, crb.Column("n_visible"))));
  std::filesystem::remove_all(dir);
}

// At zero noise the rendered spot's intensity-weighted centroid is the truth in blobs.csv.
TEST(RenderRun, SpotsSitOnTheirTruth) {
  const auto dir = TempDir();
  RenderOptions opt;
  opt.out_dir = dir;
  opt.progress = false;
  RenderScenario(Small(12, false), "", opt);
  const CsvTable blobs = CsvTable::Read(dir / "blobs.csv");
  ASSERT_GT(blobs.size(), 9u);
  const int frame = blobs.Column("frame"), camera = blobs.Column("camera");
  const int u_px = blobs.Column("u_px"), v_px = blobs.Column("v_px"), u_geom_px = blobs.Column("u_geom_px");
  int checked = 0;
  for (std::size_t r = 0; r < blobs.size(); ++r) {
    char name[32];
    std::snprintf(name, sizeof(name), "%06d.pgm", static_cast<int>(blobs.Number(r, frame)));
    const cv::Mat img = ReadPgm((dir / "frames" / blobs.Cell(r, camera) / name).string());
    const double u = blobs.Number(r, u_px), v = blobs.Number(r, v_px);
    EXPECT_EQ(blobs.Cell(r, u_px), blobs.Cell(r, u_geom_px));  // no centroid noise: rendered centre = projection
    const int cu = static_cast<int>(std::lround(u)), cv_ = static_cast<int>(std::lround(v));
    if (cu < 8 || cv_ < 8 || cu > img.cols - 9 || cv_ > img.rows - 9) continue;
    double sw = 0, su = 0, sv = 0;
    for (int y = cv_ - 7; y <= cv_ + 7; ++y)
      for (int x = cu - 7; x <= cu + 7; ++x) {
        const double w = std::max(0.0, img.at<std::uint8_t>(y, x) - 10.0);  // background 400 e = 10 DN
        sw += w;
        su += w * x;
        sv += w * y;
      }
    ASSERT_GT(sw, 0);
    EXPECT_NEAR(su / sw, u, 0.05);
    EXPECT_NEAR(sv / sw, v, 0.05);
    ++checked;
  }
  EXPECT_GT(checked, 10);
  std::filesystem::remove_all(dir);
}

// Issue 14, defect 10: a render into the folder of an earlier, longer one leaves none of the
// earlier frames behind (navd would replay them after the new run's last), keeps the user's
// other files, and leaves no temporary folder; --no-images removes the earlier frames.
TEST(RenderRun, RenderingAgainIntoAFolderLeavesNoStaleFrames) {
  const auto dir = TempDir();
  RenderOptions opt;
  opt.out_dir = dir;
  opt.progress = false;
  opt.threads = 2;
  RenderScenario(Small(3, false), "", opt);
  ASSERT_TRUE(std::filesystem::exists(dir / "frames" / "x" / "000002.pgm"));
  WriteFileAtomic(dir / "poses.csv", "frame,t_ns\n");
  RenderScenario(Small(2, false), "", opt);
  for (const char* cam : {"x", "y", "z"}) {
    EXPECT_TRUE(std::filesystem::exists(dir / "frames" / cam / "000001.pgm")) << cam;
    EXPECT_FALSE(std::filesystem::exists(dir / "frames" / cam / "000002.pgm")) << cam;
  }
  EXPECT_EQ(ReadFile(dir / "poses.csv"), "frame,t_ns\n");
  for (const auto& e : std::filesystem::directory_iterator(dir))
    EXPECT_NE(e.path().filename().string().rfind(".frames.", 0), 0u) << e.path();
  opt.write_images = false;
  RenderScenario(Small(2, false), "", opt);
  EXPECT_FALSE(std::filesystem::exists(dir / "frames"));
  std::filesystem::remove_all(dir);
}

TEST(RenderRun, SameSeedSameBytesAnyThreadCount) {
  const auto a = TempDir(), b = TempDir(), c = TempDir();
  RenderOptions opt;
  opt.progress = false;
  Scenario s = Small(3, true);
  opt.out_dir = a;
  opt.threads = 1;
  RenderScenario(s, "", opt);
  opt.out_dir = b;
  opt.threads = 3;
  RenderScenario(s, "", opt);
  s.seed = 99;
  opt.out_dir = c;
  RenderScenario(s, "", opt);
  for (const char* f : {"frames/x/000002.pgm", "frames/z/000000.pgm", "blobs.csv"}) {
    EXPECT_EQ(ReadFile(a / f), ReadFile(b / f)) << f;
    EXPECT_NE(ReadFile(a / f), ReadFile(c / f)) << f;
  }
  for (const auto& d : {a, b, c}) std::filesystem::remove_all(d);
}

}  // namespace
}  // namespace mfns::host

namespace mfns::host {
namespace {

// The station presets render like the others; the maps written carry the beacons' facing only
// when the scenario's map does (beacons.facing).
TEST(RenderRun, StationPresetWritesItsMapsWithOrWithoutFacing) {
  for (const bool facing : {true, false}) {
    const auto dir = TempDir();
    std::string yaml = PresetYaml("station-cylinder");
    if (!facing) yaml.replace(yaml.find("facing: true"), 12, "facing: false");
    Scenario s = ParseScenarioYaml(yaml, "station.yaml", ".");
    s.frames = 2;
    RenderOptions opt;
    opt.out_dir = dir;
    opt.progress = false;
    const RenderSummary sum = RenderScenario(s, yaml, opt);
    EXPECT_GT(sum.mean_visible, 0.0);
    EXPECT_TRUE(std::filesystem::exists(dir / "frames" / "z" / "000001.pgm"));
    const Rig truth = ReadRigYaml(dir / "rig.yaml"), believed = ReadRigYaml(dir / "believed-rig.yaml");
    EXPECT_EQ(truth.num_beacons, 128);
    EXPECT_EQ(truth.has_facing, facing);
    EXPECT_EQ(believed.has_facing, facing);
    if (facing) {
      EXPECT_LT((truth.beacon_normal_w[5] - s.rig.beacon_normal_w[5]).norm(), 1e-9);
    }
    // blobs.csv: true beacons only, as many as crb.csv counts.
    const CsvTable blobs = CsvTable::Read(dir / "blobs.csv");
    const CsvTable crb = CsvTable::Read(dir / "crb.csv");
    const int n_visible = crb.Column("n_visible");
    EXPECT_EQ(static_cast<int>(blobs.size()), static_cast<int>(crb.Number(0, n_visible) + crb.Number(1, n_visible)));
    std::filesystem::remove_all(dir);
  }
}

}  // namespace
}  // namespace mfns::host
