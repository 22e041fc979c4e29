// Long versions (label "slow") of the statistical tests: the paper-calibration geometry in
// full (11 turntable + 10 free images per camera), over 20 seeds, on noisy corners and on
// rendered images through detection. They print the tables of docs/calibration.md.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "host/calib/app/calib_test_util.h"
#include "host/calib/core/dataset.h"

namespace mfns::host {
namespace {

namespace fs = std::filesystem;

// Issue 5, item 6: over 20 seeds with the paper's noise (0.1 px corners, 8 arcsec angles),
// `ml` lands within 3 sigma of the truth for at least 95% of the parameters (48 per seed) and
// has lower errors than the paper's method on the same corners; its errors are the ones its
// covariance predicts (the estimator is efficient). 7 turntable + 6 free images per camera.
TEST(CalibSlow, TwentySeedsWithinThreeSigmaAndBetterThanPaper) {
  SynthOptions so;
  so.turntable_images = 7;
  so.free_images = 6;
  Tally ml, paper;
  RunCornerSeeds(20, so, 0.1, &ml, &paper);
  ml.Print("ml");
  paper.Print("paper");
  EXPECT_GE(ml.FractionWithin3(), 0.95);
  EXPECT_LT(ml.RotRms(), paper.RotRms());
  EXPECT_LT(ml.PosRms(), paper.PosRms());
  EXPECT_NEAR(ml.RotRms() / ml.RotPredicted(), 1.0, 0.3);
  EXPECT_NEAR(ml.PosRms() / ml.PosPredicted(), 1.0, 0.3);
}

TEST(CalibSlow, FullGeometryCornersTwentySeeds) {
  Tally ml, paper, handeye;
  RunCornerSeeds(20, SynthOptions{}, 0.1, &ml, &paper, &handeye);
  ml.Print("ml");
  paper.Print("paper");
  handeye.Print("opencv-handeye");
  EXPECT_GE(ml.FractionWithin3(), 0.95);
  EXPECT_LT(ml.RotRms(), paper.RotRms());
  EXPECT_LT(ml.PosRms(), paper.PosRms());
  EXPECT_LT(ml.RotRms(), handeye.RotRms());
  EXPECT_LT(ml.PosRms(), handeye.PosRms());
}

// Rendered 640x512 images (the same geometry at half the pixel count, ~0.09 px corners),
// detected with findChessboardCornersSB; the dataset files are written and read back.
TEST(CalibSlow, RenderedImagesTwentySeeds) {
  const fs::path root = fs::temp_directory_path() / ("mfns_calib_slow_" + std::to_string(::getpid()));
  Tally ml, paper, handeye;
  int skipped = 0;
  for (int seed = 1; seed <= 20; ++seed) {
    SynthOptions so;
    so.seed = static_cast<std::uint64_t>(seed);
    so.image_scale = 0.5;
    const SynthScene scene = MakeSynthScene(so);
    fs::remove_all(root);
    WriteSynthDataset(scene, SynthRender{}, so.seed, root);
    const CalibDataset ds = ReadCalibDataset(root);
    CalibInput in = DetectDataset(ds, DetectOptions{}, 2, nullptr);
    skipped += static_cast<int>(in.skipped.size());
    in.C_p_b = ds.truth.mount.C_p_b;
    in.r_p_pb = ds.truth.mount.r_p_pb;
    RigOptions ro;
    const IntrinsicsStage st = PrepareViews(&in, ro);
    ml.Add(SolveRig(in, st, ro), scene);
    ro.method = RigMethod::kPaper;
    paper.Add(SolveRig(in, st, ro), scene);
    ro.method = RigMethod::kOpenCvHandEye;
    handeye.Add(SolveRig(in, st, ro), scene);
    std::printf("seed %d done\n", seed);
  }
  fs::remove_all(root);
  std::printf("rendered images, %d skipped:\n", skipped);
  ml.Print("ml");
  paper.Print("paper");
  handeye.Print("opencv-handeye");
  EXPECT_GE(ml.FractionWithin3(), 0.95);
  EXPECT_LT(ml.RotRms(), paper.RotRms());
  EXPECT_LT(ml.PosRms(), paper.PosRms());
}

}  // namespace
}  // namespace mfns::host
