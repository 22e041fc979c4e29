// `mfns-calib rig` and `mfns-calib intrinsics` end to end on a small rendered dataset
// (host/testing/synth_calib.h written in the docs/calib-dataset.md format): every output file is
// readable by its consumer (rig reader, blob decoder, YAML, OpenCV FileStorage, headless
// Chromium for report.html) and agrees with the result.
#include "host/calib/app/calib_commands.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "common/blob/param_blob.h"
#include "common/rotation/rotation.h"
#include "host/calib/core/dataset.h"
#include "host/calib/report/compare.h"
#include "host/calib/uncertainty/cross_validation.h"
#include "host/core/xml_check_test_util.h"
#include "host/testing/synth_calib.h"
#include "host/rigio/rig_yaml.h"
#include "host/util/atomic_file.h"
#include "host/util/cli_parse.h"

namespace mfns::host {
namespace {

namespace fs = std::filesystem;

void WriteText(const fs::path& p, const std::string& text) {
  std::ofstream f(p, std::ios::binary | std::ios::trunc);
  f << text;
}

// Issue 14, defect 6 (fast: a hand-made 64x48 dataset, no rendering): a corners CSV with a
// finite but absurd coordinate (1e300 aborted Ceres in mfns-calib rig) or one far outside its
// image, or a corner repeated in an image, is refused with the file, the line and the field.
class CornersCsvRangeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("mfns_corners_range_test_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "images" / "z");
    WriteText(dir_ / "target.yaml", "type: checkerboard\ncols: 4\nrows: 3\nsquare_mm: 30\n");
    WriteText(dir_ / "images.csv", "camera,image,kind,main_deg,aux_deg\nz,000,free,,\n");
    WriteText(dir_ / "images" / "z" / "000.pgm", "P5\n64 48\n255\n" + std::string(64 * 48, '\x80'));
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string ErrorOf(const std::string& rows) {
    WriteText(dir_ / "c.csv", "camera,image,corner,u_px,v_px\n" + rows);
    try {
      CornersFromCsv(ReadCalibDataset(dir_), (dir_ / "c.csv").string());
    } catch (const UserError& e) {
      return e.what();
    }
    return "(no error)";
  }
  fs::path dir_;
};

TEST_F(CornersCsvRangeTest, AbsurdOrRepeatedCornersNameTheLineAndField) {
  const std::string csv = (dir_ / "c.csv").string();
  EXPECT_EQ(ErrorOf("z,000,0,10,12\nz,000,1,-10.5,57.5\n"), "(no error)");  // the margin's edges
  EXPECT_EQ(ErrorOf("z,000,0,10,12\nz,000,1,1e300,12\n"),
            csv + ":3: u_px: 1e+300 is outside the 64x48 image of camera z (-10.5..73.5)");
  EXPECT_EQ(ErrorOf("z,000,0,10,-1e300\n"), csv + ":2: v_px: -1e+300 is outside the 64x48 image of camera z (-10.5..57.5)");
  EXPECT_EQ(ErrorOf("z,000,0,10,57.6\n").rfind(csv + ":2: v_px: 57.6 is outside", 0), 0u);
  EXPECT_EQ(ErrorOf("z,000,0,10,12\nz,000,0,11,12\n"), csv + ":3: corner: id 0 of z/000 repeats line 2");
  EXPECT_EQ(ErrorOf("z,000,99999999999999999999,10,12\n").rfind(csv + ":2: corner id", 0), 0u);
}

// Issue 14, defect 6: a negative or non-numeric generation is refused at parse time (CLI11
// read "-1" as 2^64-1, and every later flash was refused as not newer).
TEST(GenerationOption, OnlyWholeNumbersUpTo2To64) {
  EXPECT_EQ(ParseGenerationOption("0"), 0u);
  EXPECT_EQ(ParseGenerationOption("18446744073709551615"), 18446744073709551615u);
  for (const char* bad : {"-1", "", "1e3", "x", "+5", " 5", "18446744073709551616", "0x10"}) {
    try {
      ParseGenerationOption(bad);
      ADD_FAILURE() << bad;
    } catch (const UserError& e) {
      EXPECT_EQ(std::string(e.what()).rfind("--generation: expected a whole number", 0), 0u) << e.what();
    }
  }
  // The tool: exit 1, one line naming the option, no blob.
  const fs::path dir = fs::temp_directory_path() / ("mfns_generation_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  ASSERT_EQ(std::system(("bin/mfns-calib paper-rig --out " + (dir / "rig.yaml").string()).c_str()), 0);
  const std::string cmd = "bin/mfns-calib blob " + (dir / "rig.yaml").string() + " --out " + (dir / "b.bin").string() +
                          " --generation -1 2> " + (dir / "err.txt").string();
  const int rc = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(rc));
  EXPECT_EQ(WEXITSTATUS(rc), 1);
  const std::string err = ReadFile(dir / "err.txt");
  EXPECT_EQ(err, "mfns-calib: --generation: expected a whole number 0..18446744073709551615, got \"-1\"\n");
  EXPECT_FALSE(fs::exists(dir / "b.bin"));
  fs::remove_all(dir);
}

// Issue 14 (host_cli_fuzz): the command line is parsed without running anything, and an
// argument holding a newline no longer makes a two-line error (CLI11's messages and
// --generation's quoted the argument as given; now its control characters are escaped).
TEST(CalibCommandLine, ParsesWithoutRunningAndErrorsStayOneLine) {
  const auto parse = [](const std::vector<std::string>& words) { return ParseWords(ParseCalibCommandLine, words); };
  const fs::path out = fs::temp_directory_path() / ("mfns_calib_cli_test_" + std::to_string(::getpid()));
  const CalibCommandLine cl =
      parse({"mfns-calib", "rig", "no-dataset", "--out", out.string(), "--generation", "7", "--angle-sigma-arcsec", "4"});
  EXPECT_EQ(cl.command, "rig");
  EXPECT_TRUE(cl.rig.generation_set);
  EXPECT_EQ(cl.rig.generation, 7u);
  EXPECT_TRUE(cl.rig.angle_sigma_set);
  EXPECT_FALSE(fs::exists(out));  // nothing ran
  try {
    parse({"mfns-calib", "blob", "rig.yaml", "--out", "b.bin", "--generation", "1\n2"});
    ADD_FAILURE() << "accepted";
  } catch (const UserError& e) {
    EXPECT_STREQ(e.what(), "--generation: expected a whole number 0..18446744073709551615, got \"1\\n2\"");
  }
  try {
    parse({"mfns-calib", "rig", "no-dataset", "--out", out.string(), "--jobs", "1\n2"});
    ADD_FAILURE() << "accepted";
  } catch (const CLI::ParseError& e) {
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("1\\n2"), std::string::npos) << e.what();
  }
}

// mfns-calib survey's per-recording placements: each --turntable-placement takes one file (the
// recordings after it stay recordings), in the order given; the first recording's placement as
// options includes the mount.
TEST(CalibCommandLine, SurveyTakesOnePlacementFilePerOption) {
  const CalibCommandLine cl = ParseWords(
      ParseCalibCommandLine, {"mfns-calib", "survey", "--rig", "r.yaml", "--out", "o", "--turntable", "--turntable-placement",
                              "a.yaml", "rec1", "--turntable-placement", "none", "rec2", "rec3"});
  EXPECT_EQ(cl.survey.turntable_placements, (std::vector<std::string>{"a.yaml", "none"}));
  EXPECT_EQ(cl.survey.recordings, (std::vector<std::string>{"rec1", "rec2", "rec3"}));
  EXPECT_NO_THROW(ValidateSurveyCommand(cl.survey));
  const CalibCommandLine m = ParseWords(
      ParseCalibCommandLine, {"mfns-calib", "survey", "--rig", "r.yaml", "--out", "o", "--turntable", "--turntable-mount-mm",
                              "1,2,3", "rec1", "--turntable-mount-sigma-mm", "0.05", "--initial-pose", "0,0,0,0,0,0", "rec2"});
  EXPECT_EQ(m.survey.turntable_mount_mm, (std::vector<double>{1, 2, 3}));
  EXPECT_EQ(m.survey.recordings, (std::vector<std::string>{"rec1", "rec2"}));
  EXPECT_TRUE(m.survey.turntable_mount_sigma_set);
  EXPECT_NO_THROW(ValidateSurveyCommand(m.survey));
  struct Bad {
    std::vector<std::string> words;
    const char* expected;
  };
  const Bad bad[] = {
      {{"--turntable-placement", "a.yaml", "rec1"}, "--turntable-placement: only with --turntable"},
      {{"--turntable", "--turntable-placement", "a.yaml", "--turntable-placement", "b.yaml", "rec1"},
       "--turntable-placement: 2 files for 1 recordings"},
      {{"--turntable", "--turntable-placement", "a.yaml", "--turntable-axis", "0,0,1", "rec1"},
       "--turntable-placement: not with --turntable-centre-mm"},
      {{"--turntable", "--turntable-mount-mm", "1,2,3", "rec1"}, "--turntable-mount-sigma-mm: a positive number"},
      {{"--turntable", "--turntable-mount-sigma-mm", "0.05", "rec1"}, "--turntable-mount-sigma-mm"},
      {{"--turntable", "--turntable-mount-mm", "1,nan,3", "--turntable-mount-sigma-mm", "1", "rec1"},
       "--turntable-mount-mm: expected 3 finite numbers"},
      {{"--turntable-mount-mm", "1,2,3", "--turntable-mount-sigma-mm", "1", "rec1"},
       "--turntable-mount-mm: only with --turntable"},
  };
  for (const Bad& b : bad) {
    std::vector<std::string> words = {"mfns-calib", "survey", "--rig", "r.yaml", "--out", "o"};
    words.insert(words.end(), b.words.begin(), b.words.end());
    try {
      ValidateSurveyCommand(ParseWords(ParseCalibCommandLine, words).survey);
      ADD_FAILURE() << b.expected;
    } catch (const UserError& e) {
      EXPECT_NE(std::string(e.what()).find(b.expected), std::string::npos) << e.what();
    }
  }
}

// The corner refinement is on by default (issue 18 item 1); --fast-detect (a quick look) leaves it
// out unless --refine-corners is given; --no-refine-corners turns it off; the same for intrinsics.
TEST(CalibCommandLine, CornerRefinementIsTheDefaultAndFastDetectDropsIt) {
  const auto refines = [](std::vector<std::string> flags, bool intrinsics = false) {
    std::vector<std::string> words = {"mfns-calib", intrinsics ? "intrinsics" : "rig"};
    if (intrinsics) words.insert(words.end(), {"--target", "checkerboard:9x6:20", "a.pgm", "--out", "o"});
    else words.insert(words.end(), {"no-dataset", "--out", "o"});
    words.insert(words.end(), flags.begin(), flags.end());
    const CalibCommandLine cl = ParseWords(ParseCalibCommandLine, words);
    return intrinsics ? RefineCorners(cl.intrinsics.refine_corners, cl.intrinsics.refine_corners_given,
                                      cl.intrinsics.fast_detect)
                      : RefineCorners(cl.rig.refine_corners, cl.rig.refine_corners_given, cl.rig.fast_detect);
  };
  for (const bool intrinsics : {false, true}) {
    EXPECT_TRUE(refines({}, intrinsics));
    EXPECT_TRUE(refines({"--refine-corners"}, intrinsics));
    EXPECT_FALSE(refines({"--no-refine-corners"}, intrinsics));
    EXPECT_FALSE(refines({"--fast-detect"}, intrinsics));
    EXPECT_TRUE(refines({"--fast-detect", "--refine-corners"}, intrinsics));
    EXPECT_FALSE(refines({"--fast-detect", "--no-refine-corners"}, intrinsics));
  }
  // Options built in code (not parsed) follow the same rule.
  EXPECT_TRUE(RefineCorners(RigCommandOptions{}.refine_corners, false, false));
  EXPECT_FALSE(RefineCorners(true, false, true));
  // SB's upsampled sub-pixel search only where its corners are final: not before the refinement
  // (the default), not under --fast-detect; with --no-refine-corners alone.
  EXPECT_FALSE(SbAccuracy(false, true));
  EXPECT_FALSE(SbAccuracy(true, false));
  EXPECT_FALSE(SbAccuracy(true, true));
  EXPECT_TRUE(SbAccuracy(false, false));
}

// The checks rig and intrinsics make before reading anything (ValidateRigCommand,
// ValidateIntrinsicsCommand): one line naming the option, nothing created. A --method holding a
// newline made a two-line error before (host_cli_fuzz's run-time checks, issue 14).
TEST(CalibCommandLine, RunTimeChecksNameTheOptionInOneLine) {
  const auto error = [](const auto& validate) -> std::string {
    try {
      validate();
    } catch (const UserError& e) {
      return e.what();
    }
    return "no error";
  };
  RigCommandOptions r;
  r.dataset = "no-dataset";
  r.out_dir = (fs::temp_directory_path() / ("mfns_calib_validate_" + std::to_string(::getpid()))).string();
  EXPECT_EQ(ValidateRigCommand(r), RigMethod::kMl);
  EXPECT_FALSE(fs::exists(r.out_dir));
  r.method = "m\nl";
  EXPECT_EQ(error([&] { ValidateRigCommand(r); }), "--method \"m\\nl\": expected ml, paper or opencv-handeye");
  r.method = "paper";
  r.mount_mm = {1.0, 2.0};
  EXPECT_EQ(error([&] { ValidateRigCommand(r); }), "--mount-mm: expected 3 numbers X Y Z");
  r.mount_mm.clear();
  r.cross_validate = true;  // needs ml's covariance: paper has none, and --no-covariance drops it
  EXPECT_EQ(error([&] { ValidateRigCommand(r); }),
            "--cross-validate needs --method ml with its covariance (not --no-covariance)");
  r.method = "ml";
  EXPECT_EQ(ValidateRigCommand(r), RigMethod::kMl);
  r.no_covariance = true;
  EXPECT_EQ(error([&] { ValidateRigCommand(r); }),
            "--cross-validate needs --method ml with its covariance (not --no-covariance)");
  IntrinsicsCommandOptions i;
  i.out_dir = r.out_dir;
  i.images = {"a.pgm"};
  i.target = "checkerboard:9x6:20";
  EXPECT_EQ(ValidateIntrinsicsCommand(i).corners().size(), 54u);
  i.images.clear();
  EXPECT_EQ(error([&] { ValidateIntrinsicsCommand(i); }), "no images given");
  EXPECT_FALSE(fs::exists(r.out_dir));
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

  // report.html: one scatter, histogram, per-view chart and two projection-uncertainty maps
  // (body- and camera-frame ray) per camera, the angle chart, the truth table.
  const std::string html = ReadFile(out / "report.html");
  EXPECT_EQ(Count(html, "<svg"), 16);
  EXPECT_EQ(Count(html, "<rect class=\"heat\""), 6 * 32 * 24);
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

  // And it is drawn: a screenshot of the whole page has the charts' coloured marks (points,
  // histogram and RMS bars; the rest of the page is black, grey and white text and tables).
  const fs::path png = *root_ / "report.png";
  const std::string shot = "timeout 60 chromium --headless --no-sandbox --disable-gpu --hide-scrollbars "
                           "--disable-background-networking --disable-component-update --disable-sync --no-first-run "
                           "--user-data-dir=" + profile.string() + " --window-size=1400,7000 --screenshot=" + png.string() +
                           " file://" + report.string() + " > /dev/null 2>&1";
  ASSERT_EQ(std::system(shot.c_str()), 0);
  const cv::Mat image = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty());
  int coloured = 0;
  for (int v = 0; v < image.rows; ++v)
    for (int u = 0; u < image.cols; ++u) {
      const cv::Vec3b p = image.at<cv::Vec3b>(v, u);
      coloured += std::max({p[0], p[1], p[2]}) - std::min({p[0], p[1], p[2]}) > 80 ? 1 : 0;
    }
  std::printf("report.png: %d coloured pixels\n", coloured);
  EXPECT_GT(coloured, 30000) << "the charts are not drawn in " << png;
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

// --corners: the dataset's exact corners (corners.csv) instead of detection; ml then recovers
// the rig to the turntable's 8 arcsec (the detector's own error is what limits it on images).
// --write-corners writes what was used, in the same format.
TEST_F(RigCommandTest, CornersFromCsvAndWrittenBack) {
  RigCommandOptions o = Options("ml", "exact");
  o.corners_csv = (*root_ / "data" / "corners.csv").string();
  o.write_corners_csv = (*root_ / "exact-corners.csv").string();
  std::ostringstream log;
  const RigCalibration rig = RunRigCommand(o, log);
  EXPECT_NE(log.str().find("no detection"), std::string::npos);
  const RigErrors e = CompareRig(rig, scene_->rig, &scene_->mount);
  for (const CameraError& c : e.cameras) {
    EXPECT_LT(c.rotation_deg, 0.005) << c.name;
    EXPECT_LT(c.position_mm, 0.02) << c.name;
  }
  // Same corners, same order: the written file has every row of the input.
  const std::string in = ReadFile(o.corners_csv), out = ReadFile(o.write_corners_csv);
  EXPECT_EQ(Count(out, "\n"), Count(in, "\n"));
  EXPECT_EQ(out.substr(0, out.find('\n')), "camera,image,corner,u_px,v_px");

  o.corners_csv = (*root_ / "bad-corners.csv").string();
  WriteText(o.corners_csv, "camera,image,corner,u_px,v_px\nz,000,1,2.5,x\n");
  try {
    RunRigCommand(o, log);
    ADD_FAILURE() << "no error";
  } catch (const UserError& err) {
    EXPECT_NE(std::string(err.what()).find("bad-corners.csv:2: v_px: bad pixel coordinate"), std::string::npos) << err.what();
  }
}

// The corners of a corners.csv-format file, per image ("camera/image"), read by the tool's own
// reader (CornersFromCsv).
std::map<std::string, std::vector<Eigen::Vector2d>> ReadCornerCsv(const CalibDataset& ds, const fs::path& path) {
  const CalibInput in = CornersFromCsv(ds, path.string());
  std::map<std::string, std::vector<Eigen::Vector2d>> out;
  for (const ViewObservation& v : in.views)
    for (const CornerObs& c : v.corners) out[in.cameras[static_cast<std::size_t>(v.camera)].name + "/" + v.image].push_back(c.uv);
  return out;
}

// RMS per axis of each corner's distance to the nearest exact corner of its image (the ids of
// this symmetric board are settled only later, by the turntable kinematics); *n: corners used.
double CornerRms(const std::map<std::string, std::vector<Eigen::Vector2d>>& corners,
                 const std::map<std::string, std::vector<Eigen::Vector2d>>& truth, std::size_t* n) {
  double ss = 0.0;
  *n = 0;
  for (const auto& [image, uvs] : corners) {
    const auto t = truth.find(image);
    if (t == truth.end()) continue;
    for (const Eigen::Vector2d& uv : uvs) {
      double best = 1e18;
      for (const Eigen::Vector2d& tuv : t->second) best = std::min(best, (uv - tuv).squaredNorm());
      ss += best;
      ++*n;
    }
  }
  return *n > 0 ? std::sqrt(ss / (2.0 * static_cast<double>(*n))) : 1e9;
}

// The tool's --refine-corners and --no-refine-corners (the default, accepted explicitly): the
// refined corners are closer to the dataset's exact ones, and stderr counts the refinement's
// outcomes. These images are dim (80 e on white: shot noise ~11 % of the contrast), so both are
// noise-limited: measured refined 0.061 px, SB without ACCURACY 0.092 px per axis.
TEST_F(RigCommandTest, RefineCornersFlagsChangeTheCorners) {
  const fs::path err = *root_ / "refine-stderr.txt";
  const auto run = [&](const std::string& flag, const std::string& name) {
    const std::string cmd = "bin/mfns-calib rig " + (*root_ / "data").string() + " --out " + (*root_ / name).string() +
                            " --method paper --fast-detect --generation 1 --write-corners " +
                            (*root_ / (name + ".csv")).string() + " " + flag + " 2> " + err.string();
    EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
    return ReadFile(err);
  };
  const std::string log_on = run("--refine-corners", "refined"), log_off = run("--no-refine-corners", "sb");
  const CalibDataset ds = ReadCalibDataset(*root_ / "data");
  const auto truth = ReadCornerCsv(ds, *root_ / "data" / "corners.csv");
  std::size_t n_on = 0, n_off = 0;
  const double rms_on = CornerRms(ReadCornerCsv(ds, *root_ / "refined.csv"), truth, &n_on);
  const double rms_off = CornerRms(ReadCornerCsv(ds, *root_ / "sb.csv"), truth, &n_off);
  std::printf("corners against corners.csv: refined %.4f px, SB %.4f px per axis (%zu corners)\n", rms_on, rms_off, n_on);
  ASSERT_GT(n_on, 500u);
  EXPECT_EQ(n_on, n_off);
  EXPECT_LT(rms_on, 0.8 * rms_off);
  // "corner refinement: N refined, M kept ..." on the refined run only; nearly every corner refined.
  const std::size_t at = log_on.find("corner refinement: ");
  ASSERT_NE(at, std::string::npos) << log_on;
  int refined = 0, kept = 0;
  ASSERT_EQ(std::sscanf(log_on.c_str() + at, "corner refinement: %d refined, %d kept", &refined, &kept), 2);
  EXPECT_GE(static_cast<std::size_t>(refined + kept), n_on);  // every detected corner, used or not
  EXPECT_GT(refined, static_cast<int>(0.95 * static_cast<double>(n_on)));
  EXPECT_EQ(log_off.find("corner refinement"), std::string::npos) << log_off;
}

// A copy of the dataset with some images damaged: `damage(images_dir)` edits it.
fs::path DamagedCopy(const fs::path& root, const std::string& name, void (*damage)(const fs::path&)) {
  const fs::path dir = root / name;
  fs::remove_all(dir);
  fs::copy(root / "data", dir, fs::copy_options::recursive);
  damage(dir / "images");
  return dir;
}

// Item 1: unusable images are skipped and listed with the reason (stderr and report.html).
TEST_F(RigCommandTest, SkippedImagesAreListedWithTheReason) {
  const fs::path data = DamagedCopy(*root_, "damaged", [](const fs::path& images) {
    WriteText(images / "x" / "001.pgm", "P5 garbage");                                // corrupt file
    WriteText(images / "y" / "002.pgm", "P5\n64 48\n255\n" + std::string(64 * 48, '\x80'));    // wrong size
    WriteText(images / "y" / "003.pgm", "P5\n640 512\n255\n" + std::string(640 * 512, '\x80'));  // no target
  });
  RigCommandOptions o = Options("paper", "damaged-out");
  o.dataset = data.string();
  std::ostringstream log;
  RunRigCommand(o, log);
  EXPECT_NE(log.str().find("skipped x/001: unreadable image"), std::string::npos) << log.str();
  EXPECT_NE(log.str().find("skipped y/002: image size 64x48 differs"), std::string::npos) << log.str();
  EXPECT_NE(log.str().find("skipped y/003: checkerboard not found"), std::string::npos) << log.str();
  const std::string html = ReadFile(*root_ / "damaged-out" / "report.html");
  const std::size_t at = html.find("Skipped images");
  ASSERT_NE(at, std::string::npos);
  const std::string skipped = html.substr(at);
  EXPECT_NE(skipped.find("<td class=\"l\">x</td><td class=\"l\">001</td><td class=\"l\">unreadable image"),
            std::string::npos);
  EXPECT_NE(skipped.find("<td class=\"l\">y</td><td class=\"l\">002</td><td class=\"l\">image size 64x48"),
            std::string::npos);
}

// Item 5: a failed run never replaces a good rig.yaml, whether it fails before the outputs
// (camera z has no usable image) or while writing them (report.html cannot be replaced).
TEST_F(RigCommandTest, FailedRunNeverReplacesAGoodRigYaml) {
  std::ostringstream log;
  RunRigCommand(Options("paper", "keep"), log);
  const fs::path out = *root_ / "keep";
  const std::string good = ReadFile(out / "rig.yaml");

  const fs::path broken = DamagedCopy(*root_, "broken", [](const fs::path& images) {
    for (const fs::directory_entry& e : fs::directory_iterator(images / "z")) WriteText(e.path(), "not a pgm");
  });
  RigCommandOptions o = Options("ml", "keep");
  o.dataset = broken.string();
  try {
    RunRigCommand(o, log);
    ADD_FAILURE() << "no error";
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("camera z: 0 usable images"), std::string::npos) << e.what();
  }
  EXPECT_EQ(ReadFile(out / "rig.yaml"), good);

  // The same good dataset with the other method, but report.html is a directory: the write
  // fails after calibration.bin and the rest, before rig.yaml.
  fs::remove(out / "report.html");
  fs::create_directories(out / "report.html" / "blocker");
  EXPECT_THROW(RunRigCommand(Options("ml", "keep"), log), UserError);
  EXPECT_EQ(ReadFile(out / "rig.yaml"), good);
  for (const fs::directory_entry& e : fs::directory_iterator(out))  // no temp file left behind
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}

// --cross-validate through the tool, on synthetic corners of the dataset's scene at 0.1 px
// (--corners): good corners pass (crossval.csv, the report's section, rig.yaml written); with
// camera x turned 0.5 deg in the second half's turntable images the tool exits 1 with one
// line, writes the diagnosis (report.html, crossval.csv) and keeps the good rig.yaml.
TEST_F(RigCommandTest, CrossValidateWritesItsVerdictAndAFailureKeepsTheRig) {
  const CalibInput good = SynthCorners(*scene_, 0.1, 5);
  const std::vector<int> halves = CrossValidationHalves(good);
  SynthScene moved = *scene_;
  const RigCamera& x = scene_->rig.cameras[0];
  const Eigen::Matrix3d C_k_b = x.C_k_b * ExpSO3(Eigen::Vector3d(DegToRad(0.5), 0.0, 0.0));
  for (std::size_t i = 0; i < moved.images.size(); ++i) {
    SynthImage& im = moved.images[i];
    if (im.camera == 0 && im.kind == ImageKind::kTurntable && halves[i] == 1)
      im.T_w_k = CameraInWorld(BodyInWorld(moved.mount, im.main_true, im.aux_true), C_k_b, x.r_b_bk);
  }
  WriteText(*root_ / "cv-good.csv", FormatCornersCsv(good));
  WriteText(*root_ / "cv-moved.csv", FormatCornersCsv(SynthCorners(moved, 0.1, 5)));
  const fs::path out = *root_ / "cv", err = *root_ / "cv-stderr.txt";
  const auto run = [&](const std::string& corners) {
    const std::string cmd = "bin/mfns-calib rig " + (*root_ / "data").string() + " --out " + out.string() +
                            " --cross-validate --generation 1 --corners " + (*root_ / corners).string() + " 2> " +
                            err.string();
    const int rc = std::system(cmd.c_str());
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  };
  ASSERT_EQ(run("cv-good.csv"), 0) << ReadFile(err);
  EXPECT_NE(ReadFile(err).find("cross-validation: PASS"), std::string::npos) << ReadFile(err);
  const std::string good_rig = ReadFile(out / "rig.yaml");
  EXPECT_EQ(Count(ReadFile(out / "crossval.csv"), ",yes\n"), 3) << ReadFile(out / "crossval.csv");
  EXPECT_NE(ReadFile(out / "report.html").find("<h2>Cross-validation</h2>\n<p class=\"pass\"><b>PASS"),
            std::string::npos);

  ASSERT_EQ(run("cv-moved.csv"), 1) << ReadFile(err);
  const std::string e = ReadFile(err);
  const std::string last = e.substr(e.rfind('\n', e.size() - 2) + 1);
  EXPECT_EQ(last.rfind("mfns-calib: cross-validation failed (camera x: chi2 ", 0), 0u) << last;
  EXPECT_NE(last.find("rig.yaml and calibration.bin not written"), std::string::npos) << last;
  EXPECT_EQ(ReadFile(out / "rig.yaml"), good_rig);
  const std::string csv = ReadFile(out / "crossval.csv");
  const std::size_t x_row = csv.find("\nx,");
  ASSERT_NE(x_row, std::string::npos) << csv;
  EXPECT_EQ(csv.substr(csv.find('\n', x_row + 1) - 3, 3), ",no") << csv;  // camera x fails, alone
  EXPECT_EQ(Count(csv, ",no\n"), 1) << csv;
  EXPECT_NE(ReadFile(out / "report.html").find("<b>FAIL</b>"), std::string::npos);
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

  // Corrupt dataset files: the tool names the file, exits 1, writes nothing.
  const auto run = [&](const fs::path& data, const std::string& expect) {
    const fs::path out = *root_ / "corrupt-out";
    const std::string c = "bin/mfns-calib rig " + data.string() + " --out " + out.string() + " 2> " + err.string();
    const int status = std::system(c.c_str());
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 1) << expect;
    const std::string e = ReadFile(err);
    EXPECT_EQ(Count(e, "\n"), 1) << e;
    EXPECT_NE(e.find(expect), std::string::npos) << e;
    EXPECT_FALSE(fs::exists(out / "rig.yaml"));
  };
  const fs::path bad_csv = DamagedCopy(*root_, "bad-csv", [](const fs::path& images) {
    std::ofstream(images.parent_path() / "images.csv", std::ios::app) << "z,000,turntable,abc,0\n";
  });
  run(bad_csv, "images.csv");
  const fs::path bad_target = DamagedCopy(*root_, "bad-target", [](const fs::path& images) {
    WriteText(images.parent_path() / "target.yaml", "type: checkerboard\ncols: [\n");
  });
  run(bad_target, "target.yaml");
}

}  // namespace
}  // namespace mfns::host
