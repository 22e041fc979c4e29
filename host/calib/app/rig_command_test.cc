// `mfns-calib rig` and `mfns-calib intrinsics` end to end on a small rendered dataset
// (testing/synth_calib.h written in the docs/calib-dataset.md format): every output file is
// readable by its consumer (rig reader, blob decoder, YAML, OpenCV FileStorage, headless
// Chromium for report.html) and agrees with the result.
#include "host/calib/app/calib_commands.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <sstream>

#include "common/blob/param_blob.h"
#include "common/rotation/rotation.h"
#include "host/calib/report/compare.h"
#include "host/calib/testing/synth_calib.h"
#include "host/rigio/rig_yaml.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

namespace fs = std::filesystem;

int Count(const std::string& text, const std::string& what) {
  int n = 0;
  for (std::size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

// A small dataset (640x512 cameras, 5 turntable + 4 free images per camera), made once.
class RigCommandTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = new fs::path(fs::temp_directory_path() / ("mfns_rig_command_test_" + std::to_string(::getpid())));
    fs::remove_all(*root_);
    SynthOptions so;
    so.seed = 11;
    so.image_scale = 0.5;
    so.turntable_images = 5;
    so.free_images = 4;
    scene_ = new SynthScene(MakeSynthScene(so));
    WriteSynthDataset(*scene_, SynthRender{}, so.seed, *root_ / "data");
  }
  static void TearDownTestSuite() {
    fs::remove_all(*root_);
    delete root_;
    delete scene_;
  }
  static RigCommandOptions Options(const std::string& method, const std::string& out) {
    RigCommandOptions o;
    o.dataset = (*root_ / "data").string();
    o.out_dir = (*root_ / out).string();
    o.method = method;
    o.fast_detect = true;
    o.generation = 42;
    o.generation_set = true;
    return o;
  }
  static fs::path* root_;
  static SynthScene* scene_;
};
fs::path* RigCommandTest::root_ = nullptr;
SynthScene* RigCommandTest::scene_ = nullptr;

TEST_F(RigCommandTest, MlWritesEveryOutputReadably) {
  std::ostringstream log;
  const RigCalibration rig = RunRigCommand(Options("ml", "ml"), log);
  const fs::path out = *root_ / "ml";
  EXPECT_NE(log.str().find("wrote rig.yaml"), std::string::npos);

  // rig.yaml: the rig file with sigma, equal to the result.
  const Rig file = ReadRigYaml(out / "rig.yaml");
  ASSERT_EQ(file.num_cameras, 3);
  EXPECT_TRUE(file.has_sigma);
  EXPECT_STREQ(file.rig_id.data(), scene_->rig.rig_id.data());  // the truth rig's id by default
  for (int k = 0; k < 3; ++k) {
    EXPECT_LT((file.cameras[static_cast<std::size_t>(k)].C_k_b - rig.cameras[static_cast<std::size_t>(k)].C_k_b).norm(), 1e-12);
    EXPECT_GT(file.sigma[static_cast<std::size_t>(k)].r_b_bk.x(), 0.0);
  }
  // Against the truth: a rough sanity bound (the statistics are calibrate_test's).
  const RigErrors e = CompareRig(rig, scene_->rig, &scene_->mount);
  for (const CameraError& c : e.cameras) {
    EXPECT_LT(c.rotation_deg, 0.2) << c.name;
    EXPECT_LT(c.position_mm, 3.0) << c.name;
  }

  // calibration.bin decodes to the same rig.
  const std::string blob = ReadFile(out / "calibration.bin");
  Rig decoded;
  BlobInfo info;
  ASSERT_EQ(DecodeParamBlob({reinterpret_cast<const std::uint8_t*>(blob.data()), blob.size()}, nullptr, &decoded, &info),
            BlobStatus::kOk);
  EXPECT_EQ(info.generation, 42u);
  EXPECT_EQ(decoded.num_cameras, 3);
  EXPECT_NEAR(decoded.cameras[0].intrinsics.alpha_x, rig.cameras[0].intrinsics.alpha_x, 1e-9);

  // camchain.yaml: Kalibr keys; T_cam_body maps the body origin to -C_k_b r_b_bk.
  const YAML::Node chain = YAML::LoadFile((out / "camchain.yaml").string());
  for (int k = 0; k < 3; ++k) {
    const YAML::Node cam = chain["cam" + std::to_string(k)];
    ASSERT_TRUE(cam) << k;
    EXPECT_EQ(cam["distortion_model"].as<std::string>(), "radtan");
    EXPECT_EQ(cam["intrinsics"].size(), 4u);
    EXPECT_EQ(cam["distortion_coeffs"].size(), 4u);
    EXPECT_NEAR(cam["intrinsics"][0].as<double>(), rig.cameras[static_cast<std::size_t>(k)].intrinsics.alpha_x, 1e-9);
    const Eigen::Vector3d t = -rig.cameras[static_cast<std::size_t>(k)].C_k_b * rig.cameras[static_cast<std::size_t>(k)].r_b_bk;
    for (int r = 0; r < 3; ++r) EXPECT_NEAR(cam["T_cam_body"][r][3].as<double>(), t[r], 1e-12);
    EXPECT_EQ(static_cast<bool>(cam["T_cn_cnm1"]), k > 0);
  }

  // camera-<name>.yaml: OpenCV reads it.
  for (const CameraResult& c : rig.cameras) {
    cv::FileStorage fs((out / ("camera-" + c.name + ".yaml")).string(), cv::FileStorage::READ);
    ASSERT_TRUE(fs.isOpened()) << c.name;
    cv::Mat K, D;
    fs["camera_matrix"] >> K;
    fs["distortion_coefficients"] >> D;
    EXPECT_NEAR(K.at<double>(0, 0), c.intrinsics.alpha_x, 1e-9);
    EXPECT_NEAR(K.at<double>(1, 2), c.intrinsics.v0, 1e-9);
    EXPECT_NEAR(D.at<double>(0), c.intrinsics.kc[0], 1e-12);
    EXPECT_EQ(static_cast<int>(fs["image_width"]), 640);
    EXPECT_GE(fs["views"].size(), 7u);
  }

  // report.html: one scatter, histogram and per-view chart per camera, the angle chart, the
  // truth table.
  const std::string html = ReadFile(out / "report.html");
  EXPECT_EQ(Count(html, "<svg"), 10);
  EXPECT_GT(Count(html, "class=\"res-turntable\""), 100);
  EXPECT_GE(rig.angles.size(), 12u);  // 15 turntable images, a few may be skipped
  EXPECT_EQ(Count(html, "class=\"angle-main\""), static_cast<int>(rig.angles.size()));
  EXPECT_NE(html.find("Against the simulation truth"), std::string::npos);
  EXPECT_NE(html.find("Skipped images"), std::string::npos);
}

// Item 6: report.html loads in headless Chromium and its DOM has the plots.
TEST_F(RigCommandTest, ReportLoadsInHeadlessChromium) {
  if (std::system("command -v chromium > /dev/null 2>&1") != 0) GTEST_SKIP() << "chromium not installed";
  std::ostringstream log;
  RunRigCommand(Options("paper", "paper"), log);
  const fs::path report = *root_ / "paper" / "report.html";
  const fs::path dom = *root_ / "dom.html", profile = *root_ / "chromium-profile";
  const std::string cmd = "timeout 60 chromium --headless --no-sandbox --disable-gpu --disable-background-networking "
                          "--disable-component-update --disable-sync --no-first-run --user-data-dir=" +
                          profile.string() + " --dump-dom file://" + report.string() + " > " + dom.string() +
                          " 2> /dev/null";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  const std::string text = ReadFile(dom);
  EXPECT_EQ(Count(text, "<svg"), 10);
  EXPECT_GT(Count(text, "<circle class=\"res-turntable\""), 100);
  EXPECT_GT(Count(text, "<rect class=\"bar\""), 30);
  EXPECT_NE(text.find("method</th><td class=\"l\">paper"), std::string::npos);
}

TEST_F(RigCommandTest, IntrinsicsCommandOnOneCamerasImages) {
  IntrinsicsCommandOptions o;
  o.target = "checkerboard:9x7:30";
  for (const char* im : {"000", "001", "002", "003", "004", "005", "006", "007", "008"})
    o.images.push_back((*root_ / "data" / "images" / "z" / (std::string(im) + ".pgm")).string());
  o.images.push_back((*root_ / "data" / "target.yaml").string());  // not an image: skipped with the reason
  o.out_dir = (*root_ / "intrinsics").string();
  o.camera = "z";
  o.fast_detect = true;
  std::ostringstream log;
  const ZhangResult z = RunIntrinsicsCommand(o, log);
  EXPECT_GE(z.views.size(), 7u);
  const CameraIntrinsics& truth = scene_->rig.cameras[2].intrinsics;
  EXPECT_LT(std::abs(z.camera.alpha_x - truth.alpha_x), 5.0 * z.sigma[kAlphaX]);
  EXPECT_LT(std::abs(z.camera.u0 - truth.u0), 5.0 * z.sigma[kU0]);
  cv::FileStorage fs((*root_ / "intrinsics" / "camera-z.yaml").string(), cv::FileStorage::READ);
  ASSERT_TRUE(fs.isOpened());
  const std::string report = ReadFile(*root_ / "intrinsics" / "report.txt");
  EXPECT_NE(report.find("skipped"), std::string::npos);
  EXPECT_NE(report.find("target.yaml"), std::string::npos);
}

TEST_F(RigCommandTest, UserErrorsAreOneLine) {
  std::ostringstream log;
  RigCommandOptions o = Options("ml", "bad");
  o.method = "magic";
  EXPECT_THROW(RunRigCommand(o, log), UserError);
  o = Options("ml", "bad");
  o.dataset = (*root_ / "nothing").string();
  EXPECT_THROW(RunRigCommand(o, log), UserError);
  // The tool: exit 1 and one line on stderr.
  const fs::path err = *root_ / "stderr.txt";
  const std::string cmd = "bin/mfns-calib rig " + (*root_ / "nothing").string() + " --out " + (*root_ / "x").string() +
                          " 2> " + err.string();
  const int rc = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(rc));
  EXPECT_EQ(WEXITSTATUS(rc), 1);
  const std::string text = ReadFile(err);
  EXPECT_EQ(Count(text, "\n"), 1) << text;
  EXPECT_NE(text.find("mfns-calib: "), std::string::npos);
}

}  // namespace
}  // namespace mfns::host
