// Long versions (label "slow") of the statistical tests: the paper-calibration geometry in
// full (11 turntable + 10 free images per camera), over 20 seeds, on noisy corners and on
// rendered images through detection. They print the tables of docs/calibration.md.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>

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
// detected with findChessboardCornersSB; the dataset files are written and read back. Twenty
// seeds take ~270 s on one core, most of a CI stage's test time on its own: the seeds run as
// four shards (RenderedImagesSeedsA-D, each its own ctest process, a fixture's setup), each
// writing its tallies to the build directory, and RenderedImagesTwentySeeds sums and judges
// them (a run of the binary alone runs them in this order too).
constexpr int kShards = 4, kSeedsPerShard = 5;

fs::path ShardFile(int shard) { return fs::current_path() / ("calib_slow_rendered_" + std::to_string(shard) + ".txt"); }

void RenderedShard(int shard) {
  const fs::path root = fs::temp_directory_path() / ("mfns_calib_slow_" + std::to_string(::getpid()));
  Tally ml, paper, handeye;
  int skipped = 0;
  for (int seed = 1 + shard * kSeedsPerShard; seed <= (shard + 1) * kSeedsPerShard; ++seed) {
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
  // Written whole under a temporary name, then renamed: the judge never reads half a shard.
  const fs::path out = ShardFile(shard), tmp = out.string() + ".tmp";
  std::FILE* f = std::fopen(tmp.c_str(), "w");
  ASSERT_NE(f, nullptr) << tmp;
  const bool ok = std::fprintf(f, "%d\n", skipped) > 0 && ml.Save(f) && paper.Save(f) && handeye.Save(f);
  ASSERT_EQ(std::fclose(f), 0) << tmp;
  ASSERT_TRUE(ok) << tmp;
  fs::rename(tmp, out);
}

TEST(CalibSlow, RenderedImagesSeedsA) { RenderedShard(0); }
TEST(CalibSlow, RenderedImagesSeedsB) { RenderedShard(1); }
TEST(CalibSlow, RenderedImagesSeedsC) { RenderedShard(2); }
TEST(CalibSlow, RenderedImagesSeedsD) { RenderedShard(3); }

TEST(CalibSlow, RenderedImagesTwentySeeds) {
  Tally ml, paper, handeye;
  int skipped = 0;
  for (int shard = 0; shard < kShards; ++shard) {
    const fs::path in = ShardFile(shard);
    std::FILE* f = std::fopen(in.c_str(), "r");
    ASSERT_NE(f, nullptr) << in << ": run the shards first (ctest does: a fixture)";
    Tally a, b, c;
    int s = 0;
    const bool ok = std::fscanf(f, "%d", &s) == 1 && a.Load(f) && b.Load(f) && c.Load(f);
    std::fclose(f);
    fs::remove(in);  // (a later run never judges a stale shard)
    ASSERT_TRUE(ok) << in;
    skipped += s;
    ml.Merge(a);
    paper.Merge(b);
    handeye.Merge(c);
  }
  ASSERT_EQ(ml.n, 3 * kShards * kSeedsPerShard);  // three cameras a seed
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
