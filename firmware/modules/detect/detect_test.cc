#include "firmware/modules/detect/detect.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <new>
#include <random>
#include <string>
#include <vector>

#include "common/rig/paper_rig.h"
#include "firmware/modules/detect/detect_testing.h"

// ---- Allocation counter: this binary replaces the global operator new/delete. ----
namespace {
std::atomic<long> g_news{0};
void* CountedAlloc(std::size_t n) {
  g_news.fetch_add(1, std::memory_order_relaxed);
  void* p = std::malloc(n == 0 ? 1 : n);
  if (p == nullptr) std::abort();
  return p;
}
void* CountedAlignedAlloc(std::size_t n, std::align_val_t a) {
  g_news.fetch_add(1, std::memory_order_relaxed);
  const std::size_t al = static_cast<std::size_t>(a);
  void* p = std::aligned_alloc(al, (n + al - 1) / al * al);
  if (p == nullptr) std::abort();
  return p;
}
}  // namespace

void* operator new(std::size_t n) { return CountedAlloc(n); }
void* operator new[](std::size_t n) { return CountedAlloc(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept { return CountedAlloc(n); }
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept { return CountedAlloc(n); }
void* operator new(std::size_t n, std::align_val_t a) { return CountedAlignedAlloc(n, a); }
void* operator new[](std::size_t n, std::align_val_t a) { return CountedAlignedAlloc(n, a); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

namespace mfns::fw {
namespace {

using testing::FrameBuffer;
using testing::Quantize;
using testing::Spot;
using testing::SyntheticImage;

// Index of the true spot nearest to uv, and its distance.
std::size_t Nearest(const std::vector<Spot>& spots, const Eigen::Vector2d& uv, double* dist) {
  std::size_t best = spots.size();
  double d_best = 1e300;
  for (std::size_t i = 0; i < spots.size(); ++i) {
    const double d = std::hypot(spots[i].u - uv.x(), spots[i].v - uv.y());
    if (d < d_best) {
      d_best = d;
      best = i;
    }
  }
  *dist = d_best;
  return best;
}

// Spots on a jittered grid covering the image (away from the border), sub-pixel positions.
std::vector<Spot> GridSpots(int width, int height, int nx, int ny, double peak, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> jitter(-0.5, 0.5), sig(1.2, 2.2);
  std::vector<Spot> spots;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      Spot s;
      s.u = (i + 0.5 + 0.3 * jitter(rng)) * width / nx;
      s.v = (j + 0.5 + 0.3 * jitter(rng)) * height / ny;
      s.sigma_x = sig(rng);
      s.sigma_y = s.sigma_x * (1.0 + 0.2 * jitter(rng));
      s.flux = peak * 2.0 * std::numbers::pi * s.sigma_x * s.sigma_y;
      spots.push_back(s);
    }
  }
  return spots;
}

TEST(DetectOptions, DefaultsValidAndEachBadFieldNamed) {
  const char* why = nullptr;
  EXPECT_TRUE(DetectOptions().IsValid(&why));
  struct Case {
    void (*mutate)(DetectOptions&);
    const char* field;
  };
  const Case cases[] = {
      {[](DetectOptions& o) { o.threshold_mode = static_cast<ThresholdMode>(7); }, "threshold_mode"},
      {[](DetectOptions& o) { o.fixed_threshold_dn = -1; }, "fixed_threshold_dn"},
      {[](DetectOptions& o) { o.fixed_background_dn = std::nan(""); }, "fixed_background_dn"},
      {[](DetectOptions& o) { o.tile_px = 16; }, "tile_px"},
      {[](DetectOptions& o) { o.sample_step_px = 0; }, "sample_step_px"},
      {[](DetectOptions& o) { o.tile_px = 256; o.sample_step_px = 2; }, "sample_step_px"},
      {[](DetectOptions& o) { o.k_sigma = 0.0; }, "k_sigma"},
      {[](DetectOptions& o) { o.min_contrast_dn = -1.0; }, "min_contrast_dn"},
      {[](DetectOptions& o) { o.centroid_weights = static_cast<CentroidWeights>(5); }, "centroid_weights"},
      {[](DetectOptions& o) { o.min_area_px = 0; }, "min_area_px"},
      {[](DetectOptions& o) { o.max_area_px = 2; }, "max_area_px"},
      {[](DetectOptions& o) { o.border_margin_px = -1; }, "border_margin_px"},
      {[](DetectOptions& o) { o.min_peak_above_background_dn = -1.0; }, "min_peak_above_background_dn"},
      {[](DetectOptions& o) { o.saturation_dn = 70000; }, "saturation_dn"},
      {[](DetectOptions& o) { o.saturation_policy = static_cast<SaturationPolicy>(9); }, "saturation_policy"},
      {[](DetectOptions& o) { o.max_saturated_px = -1; }, "max_saturated_px"},
      {[](DetectOptions& o) { o.max_elongation = 0.5; }, "max_elongation"},
      {[](DetectOptions& o) { o.max_blobs = limits::kMaxBlobsPerFrame + 1; }, "max_blobs"},
  };
  for (const Case& c : cases) {
    DetectOptions o;
    c.mutate(o);
    why = nullptr;
    EXPECT_FALSE(o.IsValid(&why)) << c.field;
    ASSERT_NE(why, nullptr);
    EXPECT_STREQ(why, c.field);
  }
}

TEST(BlobDetector, RejectsBadOptionsFramesAndCameraMismatch) {
  SyntheticImage img(64, 48);
  img.AddBackground(10.0);
  std::mt19937_64 rng(5);
  img.AddNoise(1.0, rng);  // (a perfectly flat frame is blank: see BlankFramesAreFlagged)
  FrameBuffer fb = Quantize(img, PixelFormat::kMono8);
  BlobList out;

  DetectOptions bad;
  bad.max_area_px = 0;
  BlobDetector bad_detector(bad);
  EXPECT_EQ(bad_detector.Detect(fb.view, nullptr, &out), DetectStatus::kBadOptions);

  BlobDetector detector;
  FrameView v = fb.view;
  v.data = nullptr;
  EXPECT_EQ(detector.Detect(v, nullptr, &out), DetectStatus::kBadFrame);
  v = fb.view;
  v.stride_bytes = v.width - 1;
  EXPECT_EQ(detector.Detect(v, nullptr, &out), DetectStatus::kBadFrame);
  v = fb.view;
  v.width = limits::kMaxImageWidth + 1;
  EXPECT_EQ(detector.Detect(v, nullptr, &out), DetectStatus::kBadFrame);
  v = fb.view;
  v.height = 0;
  EXPECT_EQ(detector.Detect(v, nullptr, &out), DetectStatus::kBadFrame);
  CameraIntrinsics cam = PaperRig().cameras[0].intrinsics;  // 1280 x 1024, not 64 x 48
  EXPECT_EQ(detector.Detect(fb.view, &cam, &out), DetectStatus::kCameraMismatch);
  EXPECT_EQ(out.count, 0);
  EXPECT_EQ(detector.counters().frames, 5u);
  EXPECT_EQ(detector.counters().bad_frames, 5u);
  EXPECT_EQ(detector.Detect(fb.view, nullptr, &out), DetectStatus::kOk);
  EXPECT_EQ(detector.counters().bad_frames, 5u);
  EXPECT_STREQ(ToString(DetectStatus::kLabelTableFull), "label table full");
}

// Issue 14 defect 8: an all-zero or all-white frame from one camera (a glitch, a blinding)
// read as "no beacon in view" and refuted the right track. A frame with no blob and every
// pixel alike carries no information: kBlankFrame, counted. Not blank: the same frame with one
// spot, or with read noise.
TEST(BlobDetector, BlankFramesAreFlagged) {
  BlobDetector detector;
  BlobList out;
  for (const PixelFormat format : {PixelFormat::kMono8, PixelFormat::kMono16})
    for (const double level : {0.0, 10.0, 1e9}) {  // (1e9: clamped to full scale)
      SyntheticImage img(96, 64);
      img.AddBackground(level);
      const FrameBuffer flat = Quantize(img, format);
      EXPECT_EQ(detector.Detect(flat.view, nullptr, &out), DetectStatus::kBlankFrame) << level;
      EXPECT_EQ(out.count, 0);
      if (level > 255.0) continue;  // (no spot shows on a saturated frame)
      img.AddSpot(Spot{40.3, 30.7, 1.0, 1.0, 3000.0});
      const FrameBuffer spot = Quantize(img, format);
      EXPECT_EQ(detector.Detect(spot.view, nullptr, &out), DetectStatus::kOk) << level;
      EXPECT_EQ(out.count, 1);
    }
  SyntheticImage dark(96, 64);
  dark.AddBackground(10.0);
  std::mt19937_64 rng(7);
  dark.AddNoise(1.5, rng);
  EXPECT_EQ(detector.Detect(Quantize(dark, PixelFormat::kMono8).view, nullptr, &out), DetectStatus::kOk);
  EXPECT_EQ(out.count, 0);
  EXPECT_EQ(detector.counters().blank_frames, 6u);
}

// Issue 14: a frame whose lower rows were never written (the transfer stopped; the buffer kept
// zeros) read as a dark lower half: its beacons "missing", nothing counted. Now kTruncatedFrame,
// counted; the blobs above the cut kept, one cut by it dropped (a border blob), the cells below
// the cut blind. mono8 and mono16, cut at row 128 and at row 200 of 256.
TEST(BlobDetector, TruncatedFramesAreCountedAndKeepTheBlobsAboveTheCut) {
  BlobDetector detector;
  BlobList out;
  for (const PixelFormat format : {PixelFormat::kMono8, PixelFormat::kMono16})
    for (const int cut : {128, 200}) {
      SyntheticImage img(320, 256);
      img.AddBackground(20.0);
      std::mt19937_64 rng(3);
      img.AddNoise(1.5, rng);
      img.AddSpot(Spot{100.3, 50.6, 1.2, 1.2, 3000.0});
      img.AddSpot(Spot{250.2, cut - 1.5, 1.2, 1.2, 3000.0});  // cut by the end of the transfer
      for (int y = cut; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) img.At(x, y) = 0.0;
      const FrameBuffer fb = Quantize(img, format);
      ASSERT_EQ(detector.Detect(fb.view, nullptr, &out), DetectStatus::kTruncatedFrame) << cut;
      EXPECT_EQ(out.counters.truncated_frames, 1u);
      EXPECT_EQ(out.rows_written, cut - 1);  // the last row written may be partial: left out
      ASSERT_EQ(out.count, 1) << cut;
      EXPECT_NEAR(out.blobs[0].uv_px.x(), 100.3, 0.1);
      EXPECT_NEAR(out.blobs[0].uv_px.y(), 50.6, 0.1);
      // Cells are 107 x 128 px: rows >= 128 are the lower three.
      EXPECT_EQ(out.blind_cells, 0b111000u) << cut;
    }
  EXPECT_EQ(detector.counters().truncated_frames, 4u);
  EXPECT_STREQ(ToString(DetectStatus::kTruncatedFrame), "truncated frame (lower rows never written)");
}

// The truncation rule does not fire on a legitimately dark frame: zero nearly everywhere with
// LEDs (a dark module; its rows above a zero band are zero too), read noise clipped at zero
// (no row wholly zero), a few zero rows only (3 < 4), or a saturated lower half (glare, whose
// cells are blind for saturation, not truncation).
TEST(BlobDetector, DarkOrSaturatedFramesAreNotTruncated) {
  BlobDetector detector;
  BlobList out;
  const auto detect = [&](SyntheticImage img) {
    img.AddSpot(Spot{100.3, 50.6, 1.2, 1.2, 3000.0});
    img.AddSpot(Spot{200.7, 220.2, 1.2, 1.2, 3000.0});
    return detector.Detect(Quantize(img, PixelFormat::kMono8).view, nullptr, &out);
  };
  SyntheticImage black(320, 256);  // zero but the LEDs
  EXPECT_EQ(detect(black), DetectStatus::kOk);
  EXPECT_EQ(out.count, 2);
  SyntheticImage clipped(320, 256);  // background 0.5 DN, noise 1 DN: about half the pixels 0
  clipped.AddBackground(0.5);
  std::mt19937_64 rng(5);
  clipped.AddNoise(1.0, rng);
  EXPECT_EQ(detect(clipped), DetectStatus::kOk);
  SyntheticImage three(320, 256);  // three zero rows under a normal background
  three.AddBackground(20.0);
  three.AddNoise(1.5, rng);
  for (int x = 0; x < three.width; ++x)
    for (int y = 253; y < 256; ++y) three.At(x, y) = 0.0;
  EXPECT_EQ(detect(three), DetectStatus::kOk);
  SyntheticImage glare(320, 256);  // the lower half saturated
  glare.AddBackground(20.0);
  glare.AddNoise(1.5, rng);
  glare.AddRect(0, 128, 319, 255, 1e4);
  EXPECT_EQ(detect(glare), DetectStatus::kOk);
  EXPECT_EQ(out.rows_written, 256);
  EXPECT_EQ(out.blind_cells, 0b111000u);
  EXPECT_EQ(out.counters.saturated_frames, 1u);
  EXPECT_EQ(detector.counters().truncated_frames, 0u);
}

// Issue 14: a camera half saturated (a lamp, the sun in a window) reports the cells of the
// saturated half blind, so that the beacons predicted there are not found missing; an LED's
// own saturated core does not blind its cell.
TEST(BlobDetector, ASaturatedRegionBlindsItsCellsAnLedDoesNot) {
  BlobDetector detector;
  BlobList out;
  SyntheticImage img(320, 256);
  img.AddBackground(20.0);
  std::mt19937_64 rng(9);
  img.AddNoise(1.5, rng);
  img.AddSpot(Spot{260.3, 60.6, 1.5, 1.5, 1e5});  // saturated core
  const FrameBuffer led = Quantize(img, PixelFormat::kMono8);
  EXPECT_EQ(detector.Detect(led.view, nullptr, &out), DetectStatus::kOk);
  ASSERT_EQ(out.count, 1);
  EXPECT_TRUE(out.blobs[0].saturated);
  EXPECT_EQ(out.blind_cells, 0u);
  img.AddRect(0, 0, 159, 255, 1e4);  // the left half saturated: columns 0 and 1 of the cells
  const FrameBuffer half = Quantize(img, PixelFormat::kMono8);
  EXPECT_EQ(detector.Detect(half.view, nullptr, &out), DetectStatus::kOk);
  EXPECT_EQ(out.count, 1);
  EXPECT_EQ(out.blind_cells, 0b011011u);
  EXPECT_EQ(out.counters.saturated_frames, 1u);
  EXPECT_EQ(BlindCellOf(106.1, 127.4, 320, 256), 0);  // the cell edges (106.17, 127.5) as the matcher sees them
  EXPECT_EQ(BlindCellOf(106.3, 127.6, 320, 256), 4);
  EXPECT_EQ(BlindCellOf(-50.0, 1e9, 320, 256), 3);
}

// Zero noise: centroids within 0.02 px of the true centres for mono8, mono16, padded strides
// and an unaligned mono16 buffer.
struct FormatCase {
  const char* name;
  PixelFormat format;
  int pad_bytes;
  int offset_bytes;
  double background;
  double peak;
  CentroidWeights weights;
};

class CentroidAccuracy : public ::testing::TestWithParam<FormatCase> {};

TEST_P(CentroidAccuracy, ZeroNoiseWithinTwoHundredthsPixel) {
  const FormatCase fc = GetParam();
  std::mt19937_64 rng(21);
  const std::vector<Spot> spots = GridSpots(1280, 1024, 8, 6, fc.peak, rng);
  SyntheticImage img(1280, 1024);
  img.AddBackground(fc.background);
  for (const Spot& s : spots) img.AddSpot(s);
  FrameBuffer fb = Quantize(img, fc.format, fc.pad_bytes, fc.offset_bytes);

  DetectOptions options;
  options.centroid_weights = fc.weights;
  BlobDetector detector(options);
  BlobList out;
  ASSERT_EQ(detector.Detect(fb.view, nullptr, &out), DetectStatus::kOk);
  ASSERT_EQ(out.count, static_cast<int>(spots.size()));
  EXPECT_NEAR(out.background_dn, fc.background, 0.5);
  std::vector<int> hits(spots.size(), 0);
  double worst = 0.0;
  for (std::size_t i = 0; i < static_cast<std::size_t>(out.count); ++i) {
    const Blob& b = out.blobs[i];
    double d = 0.0;
    const std::size_t k = Nearest(spots, b.uv_px, &d);
    ++hits[k];
    worst = std::max(worst, d);
    EXPECT_NEAR(b.background_dn, fc.background, 0.5);
    EXPECT_EQ(b.peak_dn, static_cast<int>(std::round(img.At(static_cast<int>(std::round(spots[k].u)),
                                                             static_cast<int>(std::round(spots[k].v))))))
        << "spot " << k;
    if (i > 0) {
      EXPECT_GE(out.blobs[i - 1].flux_dn, b.flux_dn);  // sorted, brightest first
    }
  }
  for (int h : hits) EXPECT_EQ(h, 1);
  EXPECT_LT(worst, 0.02);
}

INSTANTIATE_TEST_SUITE_P(
    Formats, CentroidAccuracy,
    ::testing::Values(
        FormatCase{"Mono8", PixelFormat::kMono8, 0, 0, 12.0, 200.0, CentroidWeights::kAboveThreshold},
        FormatCase{"Mono8OddStride", PixelFormat::kMono8, 13, 0, 12.0, 200.0, CentroidWeights::kAboveThreshold},
        FormatCase{"Mono16", PixelFormat::kMono16, 0, 0, 800.0, 40000.0, CentroidWeights::kAboveThreshold},
        FormatCase{"Mono16PaddedUnaligned", PixelFormat::kMono16, 6, 1, 800.0, 40000.0,
                   CentroidWeights::kAboveThreshold},
        FormatCase{"Mono16AboveBackground", PixelFormat::kMono16, 6, 0, 800.0, 40000.0,
                   CentroidWeights::kAboveBackground}),
    [](const ::testing::TestParamInfo<FormatCase>& p) { return std::string(p.param.name); });

// First-order scatter (1-sigma, px, along x) of the default centroid (weights I - t over the
// footprint I > t, t = contrast above background) under white noise of sigma_n DN (plus 1/12
// DN^2 of quantisation): var(u) = sigma^2 sum (x - u)^2 / (sum w)^2. And the Cramer-Rao bound
// of any unbiased estimator of u from the same pixels: 1 / sum (dI/du)^2 * sigma^2.
struct Scatter {
  double first_order = 0.0;
  double crb = 0.0;
};

Scatter ExpectedScatter(const Spot& s, double contrast, double sigma_n) {
  const double var_n = sigma_n * sigma_n + 1.0 / 12.0;
  const int r = static_cast<int>(std::ceil(8.0 * std::max(s.sigma_x, s.sigma_y))) + 2;
  double sw = 0.0, sxx = 0.0, fisher = 0.0;
  for (int y = static_cast<int>(s.v) - r; y <= static_cast<int>(s.v) + r; ++y) {
    for (int x = static_cast<int>(s.u) - r; x <= static_cast<int>(s.u) + r; ++x) {
      const double fy = testing::PixelFraction(y, s.v, s.sigma_y);
      const double I = s.flux * fy * testing::PixelFraction(x, s.u, s.sigma_x);
      const double h = 1e-5;
      const double dI = s.flux * fy *
                        (testing::PixelFraction(x, s.u + h, s.sigma_x) - testing::PixelFraction(x, s.u - h, s.sigma_x)) /
                        (2.0 * h);
      fisher += dI * dI / var_n;
      if (I > contrast) {
        sw += I - contrast;
        sxx += (x - s.u) * (x - s.u);
      }
    }
  }
  return {std::sqrt(var_n * sxx) / sw, 1.0 / std::sqrt(fisher)};
}

// With noise: the centroid scatter agrees with the first-order prediction, the centroid is
// unbiased, and it is within 1.5x of the Cramer-Rao bound.
TEST(BlobDetector, NoisyCentroidScatterMatchesPrediction) {
  const double kBackground = 20.0, kNoise = 2.0, kPeak = 120.0, kSigma = 1.5;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> sub(-0.5, 0.5);
  BlobDetector detector;
  BlobList out;
  const int kFrames = 300;
  double sum_du = 0.0, sum_dv = 0.0, sum_du2 = 0.0, sum_dv2 = 0.0, sum_pred2 = 0.0, sum_crb2 = 0.0;
  for (int f = 0; f < kFrames; ++f) {
    Spot s;
    s.u = 48.0 + sub(rng);
    s.v = 40.0 + sub(rng);
    s.sigma_x = s.sigma_y = kSigma;
    s.flux = kPeak * 2.0 * std::numbers::pi * kSigma * kSigma;
    SyntheticImage img(96, 80);
    img.AddBackground(kBackground);
    img.AddSpot(s);
    img.AddNoise(kNoise, rng);
    FrameBuffer fb = Quantize(img, PixelFormat::kMono8);
    ASSERT_EQ(detector.Detect(fb.view, nullptr, &out), DetectStatus::kOk);
    ASSERT_EQ(out.count, 1) << "frame " << f;
    const Blob& b = out.blobs[0];
    const double du = b.uv_px.x() - s.u, dv = b.uv_px.y() - s.v;
    sum_du += du;
    sum_dv += dv;
    sum_du2 += du * du;
    sum_dv2 += dv * dv;
    const Scatter e = ExpectedScatter(s, out.contrast_dn, kNoise);
    sum_pred2 += e.first_order * e.first_order;
    sum_crb2 += e.crb * e.crb;
  }
  const double pred = std::sqrt(sum_pred2 / kFrames), crb = std::sqrt(sum_crb2 / kFrames);
  const double rms_u = std::sqrt(sum_du2 / kFrames), rms_v = std::sqrt(sum_dv2 / kFrames);
  EXPECT_GT(pred, 0.01);  // noise dominates quantisation: the test is meaningful
  EXPECT_GT(rms_u, 0.8 * pred);
  EXPECT_LT(rms_u, 1.25 * pred);
  EXPECT_GT(rms_v, 0.8 * pred);
  EXPECT_LT(rms_v, 1.25 * pred);
  EXPECT_LT(rms_u, 1.5 * crb);
  EXPECT_LT(rms_v, 1.5 * crb);
  // Unbiased: the mean error is within 4 standard errors.
  EXPECT_LT(std::abs(sum_du / kFrames), 4.0 * pred / std::sqrt(kFrames));
  EXPECT_LT(std::abs(sum_dv / kFrames), 4.0 * pred / std::sqrt(kFrames));
}

// ---- Gates: each object is rejected by its own gate, a good spot in the same frame passes.

struct GateScene {
  SyntheticImage img{320, 256};
  Spot good;
  GateScene() {
    img.AddBackground(15.0);
    good.u = 250.3;
    good.v = 190.7;
    good.flux = 150.0 * 2.0 * std::numbers::pi * 1.5 * 1.5;
    img.AddSpot(good);
  }
};

void ExpectOnlyGood(const BlobList& out, const Spot& good) {
  ASSERT_EQ(out.count, 1);
  EXPECT_NEAR(out.blobs[0].uv_px.x(), good.u, 0.03);
  EXPECT_NEAR(out.blobs[0].uv_px.y(), good.v, 0.03);
}

std::uint64_t SumOfRejections(const DetectCounters& c) {
  return c.rejected_small + c.rejected_large + c.rejected_border + c.rejected_faint +
         c.rejected_saturated + c.rejected_elongated;
}

TEST(BlobGates, TooSmallSpeck) {
  GateScene scene;
  scene.img.AddRect(60, 60, 60, 60, 120.0);  // a hot pixel
  scene.img.AddRect(100, 60, 101, 60, 120.0);  // two pixels
  FrameBuffer fb = Quantize(scene.img, PixelFormat::kMono8);
  BlobDetector detector;
  BlobList out;
  ASSERT_EQ(detector.Detect(fb.view, nullptr, &out), DetectStatus::kOk);
  ExpectOnlyGood(out, scene.good);
  EXPECT_EQ(out.counters.rejected_small, 2u);
  EXPECT_EQ(SumOfRejections(out.counters), 2u);
  EXPECT_EQ(out.counters.components, 3u);
}

TEST(BlobGates, LargeBrightRegion) {
  GateScene scene;
  scene.img.AddRect(40, 40, 79, 69, 100.0);  // 40 x 30 = 1200 px, a lit window
  FrameBuffer fb = Quantize(scene.img, PixelFormat::kMono8);
  DetectOptions options;
  options.max_area_px = 500;
  BlobDetector detector(options);
  BlobList out;
  ASSERT_EQ(detector.Detect(fb.view, nullptr, &out), DetectStatus::kOk);
  ExpectOnlyGood(out, scene.good);
  EXPECT_EQ(out.counters.rejected_large, 1u);
  EXPECT_EQ(SumOfRejections(out.counters), 1u);
}

TEST(BlobGates, ElongatedStreak) {
  GateScene scene;
  Spot streak;
  streak.u = 100.2;
  streak.v = 80.6;
  streak.sigma_x = 7.0;
  streak.sigma_y = 1.0;
  streak.flux = 150.0 * 2.0 * std::numbers::pi * 7.0;
  scene.img.AddSpot(streak);
  FrameBuffer fb = Quantize(scene.img, PixelFormat::kMono8);
  BlobDetector detector;
  BlobList out;
  ASSERT_EQ(detector.Detect(fb.view, nullptr, &out), DetectStatus::kOk);
  ExpectOnlyGood(out, scene.good);
  EXPECT_EQ(out.counters.rejected_elongated, 1u);
  EXPECT_EQ(SumOfRejections(out.counters), 1u);

  // The same streak passes when the shape gate is opened, and its elongation is about
  // sigma_x / sigma_y (a Gaussian's second moments are its sigma^2, plus 1/12 px^2).
  DetectOptions open;
  open.max_elongation = 100.0;
  BlobDetector open_detector(open);
  ASSERT_EQ(open_detector.Detect(fb.view, nullptr, &out), DetectStatus::kOk);
  ASSERT_EQ(out.count, 2);
  const Blob& s = out.blobs[0].elongation > out.blobs[1].elongation ? out.blobs[0] : out.blobs[1];
  EXPECT_NEAR(s.uv_px.x(), streak.u, 0.03);
  EXPECT_NEAR(s.uv_px.y(), streak.v, 0.03);
  EXPECT_GT(s.elongation, 4.0);
  EXPECT_LT(s.elongation, 7.5);
  EXPECT_LT(std::abs(s.m_xy), 0.05 * s.m_xx);
}

TEST(BlobGates, SaturatedBlobRejectedOrFlagged) {
  GateScene scene;
  Spot hot;
  hot.u = 120.4;
  hot.v = 100.1;
  hot.flux = 2000.0 * 2.0 * std::numbers::pi * 1.5 * 1.5;  // clipped at 255
  scene.img.AddSpot(hot);
  FrameBuffer fb = Quantize(scene.img, PixelFormat::kMono8);
  int clipped = 0;
  for (int y = 0; y < scene.img.height; ++y)
    for (int x = 0; x < scene.img.width; ++x) clipped += scene.img.At(x, y) >= 254.5 ? 1 : 0;
  ASSERT_GT(clipped, 4);

  DetectOptions options;
  options.saturation_policy = SaturationPolicy::kReject;
  options.max_saturated_px = 2;
  BlobDetector detector(options);
  BlobList out;
  ASSERT_EQ(detector.Detect(fb.view, nullptr, &out), DetectStatus::kOk);
  ExpectOnlyGood(out, scene.good);
  EXPECT_EQ(out.counters.rejected_saturated, 1u);
  EXPECT_EQ(SumOfRejections(out.counters), 1u);

  options.saturation_policy = SaturationPolicy::kFlag;
  BlobDetector flagging(options);
  ASSERT_EQ(flagging.Detect(fb.view, nullptr, &out), DetectStatus::kOk);
  ASSERT_EQ(out.count, 2);
  EXPECT_TRUE(out.blobs[0].saturated);  // the brightest
  EXPECT_EQ(out.blobs[0].saturated_px, clipped);
  EXPECT_EQ(out.blobs[0].peak_dn, 255);
  EXPECT_FALSE(out.blobs[1].saturated);
  EXPECT_EQ(out.counters.flagged_saturated, 1u);
  EXPECT_EQ(SumOfRejections(out.counters), 0u);
  EXPECT_NEAR(out.blobs[0].uv_px.x(), hot.u, 0.05);  // clipping is symmetric about the centre
  EXPECT_NEAR(out.blobs[0].uv_px.y(), hot.v, 0.05);

  // A lower saturation level (a 10-bit sensor in a 16-bit word) counts from there.
  options.saturation_dn = 200;
  BlobDetector low(options);
  ASSERT_EQ(low.Detect(fb.view, nullptr, &out), DetectStatus::kOk);
  int above200 = 0;
  for (int y = 0; y < scene.img.height; ++y)
    for (int x = 0; x < scene.img.width; ++x) above200 += std::round(scene.img.At(x, y)) >= 200 ? 1 : 0;
  EXPECT_EQ(out.blobs[0].saturated_px, above200);
}

TEST(BlobGates, TouchingTheBorder) {
  GateScene scene;
  Spot edge;
  edge.u = 1.2;
  edge.v = 100.5;
  edge.flux = 150.0 * 2.0 * std::numbers::pi * 1.5 * 1.5;
  scene.img.AddSpot(edge);
  Spot near;  // 5 px from the bottom edge: passes margin 0, rejected with margin 4
  near.u = 160.0;
  near.v = 250.8;
  near.sigma_x = near.sigma_y = 0.8;
  near.flux = 150.0 * 2.0 * std::numbers::pi * 0.64;
  scene.img.AddSpot(near);
  FrameBuffer fb = Quantize(scene.img, PixelFormat::kMono8);
  BlobDetector detector;
  BlobList out;
  ASSERT_EQ(detector.Detect(fb.view, nullptr, &out), DetectStatus::kOk);
  EXPECT_EQ(out.count, 2);
  EXPECT_EQ(out.counters.rejected_border, 1u);
  EXPECT_EQ(SumOfRejections(out.counters), 1u);

  DetectOptions options;
  options.border_margin_px = 4;
  BlobDetector margin(options);
  ASSERT_EQ(margin.Detect(fb.view, nullptr, &out), DetectStatus::kOk);
  ExpectOnlyGood(out, scene.good);
  EXPECT_EQ(out.counters.rejected_border, 2u);

  options.reject_border = false;
  BlobDetector keep(options);
  ASSERT_EQ(keep.Detect(fb.view, nullptr, &out), DetectStatus::kOk);
  EXPECT_EQ(out.count, 3);
  EXPECT_EQ(out.counters.rejected_border, 0u);
}

TEST(BlobGates, FaintPeak) {
  GateScene scene;
  Spot faint;  // above the threshold (bg + 4 DN at zero noise), below the 10 DN peak gate
  faint.u = 80.5;
  faint.v = 70.2;
  faint.flux = 8.0 * 2.0 * std::numbers::pi * 1.5 * 1.5;
  scene.img.AddSpot(faint);
  FrameBuffer fb = Quantize(scene.img, PixelFormat::kMono8);
  BlobDetector detector;
  BlobList out;
  ASSERT_EQ(detector.Detect(fb.view, nullptr, &out), DetectStatus::kOk);
  ExpectOnlyGood(out, scene.good);
  EXPECT_EQ(out.counters.rejected_faint, 1u);
  EXPECT_EQ(SumOfRejections(out.counters), 1u);
}

// More blobs than the output holds: the brightest kMaxBlobsPerFrame are kept, sorted; the rest
// are counted.
TEST(BlobDetector, BlobLimitKeepsBrightestAndCounts) {
  std::mt19937_64 rng(3);
  std::vector<Spot> spots = GridSpots(1280, 1024, 20, 15, 100.0, rng);  // 300 spots
  std::uniform_real_distribution<double> peak(40.0, 200.0);
  for (Spot& s : spots) {
    s.sigma_x = s.sigma_y = 1.5;
    s.flux = peak(rng) * 2.0 * std::numbers::pi * 1.5 * 1.5;
  }
  SyntheticImage img(1280, 1024);
  img.AddBackground(10.0);
  for (const Spot& s : spots) img.AddSpot(s);
  FrameBuffer fb = Quantize(img, PixelFormat::kMono8);
  BlobDetector detector;
  BlobList out;
  ASSERT_EQ(detector.Detect(fb.view, nullptr, &out), DetectStatus::kBlobLimit);
  ASSERT_EQ(out.count, limits::kMaxBlobsPerFrame);
  const int extra = static_cast<int>(spots.size()) - limits::kMaxBlobsPerFrame;
  EXPECT_EQ(out.counters.over_blob_limit, static_cast<std::uint64_t>(extra));
  EXPECT_EQ(detector.counters().over_blob_limit, static_cast<std::uint64_t>(extra));
  // The kept ones are the brightest by true flux.
  std::vector<double> fluxes;
  for (const Spot& s : spots) fluxes.push_back(s.flux);
  std::sort(fluxes.begin(), fluxes.end(), std::greater<>());
  const double cut = 0.5 * (fluxes[limits::kMaxBlobsPerFrame - 1] + fluxes[limits::kMaxBlobsPerFrame]);
  for (std::size_t i = 0; i < static_cast<std::size_t>(out.count); ++i) {
    double d = 0.0;
    const std::size_t k = Nearest(spots, out.blobs[i].uv_px, &d);
    EXPECT_LT(d, 0.05);
    EXPECT_GT(spots[k].flux, cut);
    if (i > 0) {
      EXPECT_GE(out.blobs[i - 1].flux_dn, out.blobs[i].flux_dn);
    }
  }

  DetectOptions few;
  few.max_blobs = 10;
  BlobDetector ten(few);
  ASSERT_EQ(ten.Detect(fb.view, nullptr, &out), DetectStatus::kBlobLimit);
  EXPECT_EQ(out.count, 10);
  EXPECT_EQ(out.counters.over_blob_limit, spots.size() - 10);
}

// A label table too small for the frame: the frame is cut at the row where it ran out, blobs
// closed before are kept and the event is counted.
TEST(BlobDetector, LabelTableFullKeepsBlobsClosedBefore) {
  SyntheticImage img(320, 200);
  img.AddBackground(10.0);
  std::vector<Spot> top;
  for (int i = 0; i < 3; ++i) {
    Spot s;
    s.u = 50.0 + 100.0 * i + 0.3;
    s.v = 30.4;
    s.flux = 150.0 * 2.0 * std::numbers::pi * 2.25;
    top.push_back(s);
    img.AddSpot(s);
  }
  for (int i = 0; i < 12; ++i) {  // a row of 12 spots opening 12 components at once
    Spot s;
    s.u = 20.0 + 25.0 * i;
    s.v = 120.0;
    s.flux = 150.0 * 2.0 * std::numbers::pi * 2.25;
    img.AddSpot(s);
  }
  FrameBuffer fb = Quantize(img, PixelFormat::kMono8);
  DetectOptions options;
  options.threshold_mode = ThresholdMode::kFixed;
  options.fixed_threshold_dn = 20;
  options.fixed_background_dn = 10.0;
  BlobDetector small(options, 8);
  BlobList out;
  ASSERT_EQ(small.Detect(fb.view, nullptr, &out), DetectStatus::kLabelTableFull);
  ASSERT_EQ(out.count, 3);
  for (std::size_t i = 0; i < static_cast<std::size_t>(out.count); ++i) {
    double d = 0.0;
    Nearest(top, out.blobs[i].uv_px, &d);
    EXPECT_LT(d, 0.03);
  }
  EXPECT_EQ(out.counters.label_table_full, 1u);
  EXPECT_EQ(out.counters.open_discarded, 8u);

  BlobDetector full(options);
  EXPECT_EQ(full.Detect(fb.view, nullptr, &out), DetectStatus::kOk);
  EXPECT_EQ(out.count, 15);
}

// A strong background gradient: one global threshold cannot separate the spots, the adaptive
// one finds every spot, no false blob, and subtracts the local background.
TEST(BlobDetector, AdaptiveThresholdFollowsBackgroundGradient) {
  const double kLevel = 100.0, kGx = 0.1, kGy = 0.04, kPeak = 60.0, kNoise = 1.5;  // DN, DN/px
  std::mt19937_64 rng(9);
  const std::vector<Spot> spots = GridSpots(1280, 1024, 10, 8, kPeak, rng);
  SyntheticImage img(1280, 1024);
  img.AddBackground(kLevel, kGx, kGy);
  for (const Spot& s : spots) img.AddSpot(s);
  img.AddNoise(kNoise, rng);
  FrameBuffer fb = Quantize(img, PixelFormat::kMono8);

  const double span = kGx * 1279 + kGy * 1023;
  ASSERT_GT(span, 2.5 * kPeak);  // the gradient dwarfs the spots' contrast

  BlobDetector detector;
  BlobList out;
  ASSERT_EQ(detector.Detect(fb.view, nullptr, &out), DetectStatus::kOk);
  EXPECT_NEAR(out.noise_dn, std::sqrt(kNoise * kNoise + 1.0 / 12.0), 0.15);
  EXPECT_GT(out.threshold_max_dn - out.threshold_min_dn, 0.8 * span);
  ASSERT_EQ(out.count, static_cast<int>(spots.size()));
  std::vector<int> hits(spots.size(), 0);
  for (std::size_t i = 0; i < static_cast<std::size_t>(out.count); ++i) {
    const Blob& b = out.blobs[i];
    double d = 0.0;
    const std::size_t k = Nearest(spots, b.uv_px, &d);
    ++hits[k];
    const Scatter e = ExpectedScatter(spots[k], out.contrast_dn, kNoise);
    EXPECT_LT(d, 4.5 * e.first_order + 0.02) << "spot " << k;  // 2-D, both axes
    const double true_bg = kLevel + kGx * (b.uv_px.x() - 639.5) + kGy * (b.uv_px.y() - 511.5);
    EXPECT_NEAR(b.background_dn, true_bg, 0.6);
  }
  for (int h : hits) EXPECT_EQ(h, 1);

  // Any single fixed threshold either misses spots on the bright side or floods the dark side.
  for (int t = 0; t < 255; t += 10) {
    DetectOptions fixed;
    fixed.threshold_mode = ThresholdMode::kFixed;
    fixed.fixed_threshold_dn = t;
    BlobDetector f(fixed);
    f.Detect(fb.view, nullptr, &out);
    int good = 0;
    for (std::size_t i = 0; i < static_cast<std::size_t>(out.count); ++i) {
      double d = 0.0;
      Nearest(spots, out.blobs[i].uv_px, &d);
      good += d < 0.5 ? 1 : 0;
    }
    EXPECT_LT(good, static_cast<int>(spots.size())) << "fixed threshold " << t;
  }
}

// Undistortion: Blob::x_n agrees with mfns::Unproject of the true centre, and projects back
// onto the blob's centroid.
TEST(BlobDetector, NormalisedCoordinatesMatchUnprojectOfTrueCentre) {
  const Rig rig = PaperRig();
  const CameraIntrinsics& cam = rig.cameras[0].intrinsics;
  std::mt19937_64 rng(17);
  const std::vector<Spot> spots = GridSpots(cam.width, cam.height, 7, 5, 180.0, rng);
  SyntheticImage img(cam.width, cam.height);
  img.AddBackground(8.0);
  for (const Spot& s : spots) img.AddSpot(s);
  FrameBuffer fb = Quantize(img, PixelFormat::kMono8);
  BlobDetector detector;
  BlobList out;
  ASSERT_EQ(detector.Detect(fb.view, &cam, &out), DetectStatus::kOk);
  ASSERT_EQ(out.count, static_cast<int>(spots.size()));
  EXPECT_EQ(out.counters.undistort_failures, 0u);
  for (std::size_t i = 0; i < static_cast<std::size_t>(out.count); ++i) {
    const Blob& b = out.blobs[i];
    ASSERT_TRUE(b.normalised_ok);
    double d = 0.0;
    const Spot& s = spots[Nearest(spots, b.uv_px, &d)];
    Eigen::Vector2d x_true;
    ASSERT_EQ(Unproject(cam, Eigen::Vector2d(s.u, s.v), &x_true), UnprojectStatus::kOk);
    // 0.02 px of centroid error is 0.02 / alpha in normalised units (distortion ~ 1).
    EXPECT_LT((b.x_n - x_true).norm() * cam.alpha_x, 0.025);
    Eigen::Vector2d uv_back;
    ASSERT_EQ(Project(cam, Eigen::Vector3d(b.x_n.x(), b.x_n.y(), 1.0), &uv_back), ProjectStatus::kOk);
    EXPECT_LT((uv_back - b.uv_px).norm(), 1e-6);
  }
  // A centroid the model cannot undistort is counted, the blob kept.
  CameraIntrinsics wild = cam;
  wild.kc = {-5.0, 50.0, 0.0, 0.0, -400.0};
  ASSERT_EQ(detector.Detect(fb.view, &wild, &out), DetectStatus::kOk);
  int failed = 0;
  for (std::size_t i = 0; i < static_cast<std::size_t>(out.count); ++i) failed += out.blobs[i].normalised_ok ? 0 : 1;
  EXPECT_GT(failed, 0);
  EXPECT_EQ(out.counters.undistort_failures, static_cast<std::uint64_t>(failed));
}

// ---- An independent reference that runs everywhere (aarch64 too): flood fill with a queue,
// written differently from the streaming labeller, on random dense binary-ish images that make
// many merges (U shapes, spirals, percolating clusters).
struct RefComponent {
  int area = 0;
  int x_min = 1 << 30, y_min = 1 << 30, x_max = -1, y_max = -1;
  double s0 = 0.0, sx = 0.0, sy = 0.0, flux = 0.0;
  int peak = 0;
};

std::vector<RefComponent> FloodFill(const FrameView& f, int threshold, double background,
                                    CentroidWeights weights) {
  std::vector<int> seen(static_cast<std::size_t>(f.width) * static_cast<std::size_t>(f.height), 0);
  std::vector<RefComponent> out;
  std::vector<std::pair<int, int>> queue;
  for (int y0 = 0; y0 < f.height; ++y0) {
    for (int x0 = 0; x0 < f.width; ++x0) {
      if (seen[static_cast<std::size_t>(y0 * f.width + x0)] || f.At(x0, y0) <= threshold) continue;
      RefComponent c;
      queue.assign(1, {x0, y0});
      seen[static_cast<std::size_t>(y0 * f.width + x0)] = 1;
      for (std::size_t q = 0; q < queue.size(); ++q) {
        const auto [x, y] = queue[q];
        const int p = f.At(x, y);
        double w = p;
        if (weights == CentroidWeights::kAboveBackground) w = std::max(p - background, 0.0);
        if (weights == CentroidWeights::kAboveThreshold) w = std::max(p - static_cast<double>(threshold), 0.0);
        ++c.area;
        c.flux += std::max(p - background, 0.0);
        c.s0 += w;
        c.sx += w * x;
        c.sy += w * y;
        c.peak = std::max(c.peak, p);
        c.x_min = std::min(c.x_min, x);
        c.x_max = std::max(c.x_max, x);
        c.y_min = std::min(c.y_min, y);
        c.y_max = std::max(c.y_max, y);
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            const int xn = x + dx, yn = y + dy;
            if (xn < 0 || yn < 0 || xn >= f.width || yn >= f.height) continue;
            if (seen[static_cast<std::size_t>(yn * f.width + xn)] || f.At(xn, yn) <= threshold) continue;
            seen[static_cast<std::size_t>(yn * f.width + xn)] = 1;
            queue.push_back({xn, yn});
          }
        }
      }
      out.push_back(c);
    }
  }
  return out;
}

TEST(BlobDetector, StreamingLabelsMatchFloodFillOnRandomImages) {
  std::mt19937_64 rng(77);
  std::uniform_int_distribution<int> pix(0, 1000);
  DetectOptions options;
  options.threshold_mode = ThresholdMode::kFixed;
  options.fixed_threshold_dn = 500;
  options.fixed_background_dn = 450.0;
  options.min_area_px = 1;
  options.max_area_px = 1 << 30;
  options.reject_border = false;
  options.min_peak_above_background_dn = 0.0;
  options.saturation_policy = SaturationPolicy::kAccept;
  options.max_elongation = 1e9;
  BlobList out;
  for (int trial = 0; trial < 40; ++trial) {
    const PixelFormat format = trial % 2 == 0 ? PixelFormat::kMono16 : PixelFormat::kMono8;
    const int w = 24 + trial * 3, h = 16 + trial * 2;
    SyntheticImage img(w, h);
    const double density = 0.2 + 0.01 * trial;  // up to beyond the percolation threshold
    for (double& v : img.value) {
      const bool on = pix(rng) < density * 1000;
      v = format == PixelFormat::kMono16 ? (on ? 501 + pix(rng) : pix(rng) / 2) : (on ? 201 + pix(rng) % 50 : 0);
    }
    FrameBuffer fb = Quantize(img, format, trial % 3);
    DetectOptions o = options;
    o.centroid_weights = static_cast<CentroidWeights>(trial % 3);
    if (format == PixelFormat::kMono8) {
      o.fixed_threshold_dn = 200;
      o.fixed_background_dn = 190.0;
    }
    BlobDetector d(o);
    const std::vector<RefComponent> ref = FloodFill(fb.view, o.fixed_threshold_dn, o.fixed_background_dn, o.centroid_weights);
    ASSERT_LE(ref.size(), static_cast<std::size_t>(limits::kMaxBlobsPerFrame)) << "trial " << trial;
    ASSERT_EQ(d.Detect(fb.view, nullptr, &out), DetectStatus::kOk);
    ASSERT_EQ(out.count, static_cast<int>(ref.size())) << "trial " << trial;
    std::vector<int> used(ref.size(), 0);
    for (std::size_t i = 0; i < static_cast<std::size_t>(out.count); ++i) {
      const Blob& b = out.blobs[i];
      std::size_t match = ref.size();
      for (std::size_t r = 0; r < ref.size(); ++r)
        if (!used[r] && ref[r].x_min == b.x_min && ref[r].y_min == b.y_min && ref[r].x_max == b.x_max &&
            ref[r].y_max == b.y_max && ref[r].area == b.area_px &&
            std::abs(ref[r].sx / ref[r].s0 - b.uv_px.x()) < 1e-9 &&
            std::abs(ref[r].sy / ref[r].s0 - b.uv_px.y()) < 1e-9)
          match = r;
      ASSERT_LT(match, ref.size()) << "trial " << trial << " blob " << i;
      used[match] = 1;
      EXPECT_EQ(b.peak_dn, ref[match].peak);
      EXPECT_NEAR(b.flux_dn, ref[match].flux, 1e-9 * ref[match].flux);
    }
  }
}

// ---- Issue 20 item 2: the fast path (chunk skip against a lower bound of the thresholds, lazy
// row thresholds, histogram statistics) gives the BlobList of the per-pixel reference path
// (DetectOptions::reference_path) bit for bit: every blob field, the frame's background, noise,
// thresholds, blind cells, rows and counters, and the status. Random frames: sizes that are and
// are not multiples of the 128-px chunk and the 16-px segment, mono8 and mono16 (padded strides,
// unaligned), flat or sloped backgrounds (to 0.25 DN/px: 160 DN across 640 px, thresholds a few DN above),
// noise, spots anywhere including across the borders, saturated spots and a bright rectangle,
// a truncated frame, a tiny label table; adaptive (several tile sizes and sample steps, with and
// without the mesh median) and fixed thresholds, every centroid weighting.
void ExpectSameBlobList(const BlobList& a, const BlobList& b, const std::string& where) {
  ASSERT_EQ(a.count, b.count) << where;
  for (std::size_t i = 0; i < static_cast<std::size_t>(a.count); ++i) {
    const Blob& x = a.blobs[i];
    const Blob& y = b.blobs[i];
    const std::string at = where + " blob " + std::to_string(i);
    EXPECT_EQ(x.uv_px.x(), y.uv_px.x()) << at;
    EXPECT_EQ(x.uv_px.y(), y.uv_px.y()) << at;
    EXPECT_EQ(x.x_n.x(), y.x_n.x()) << at;
    EXPECT_EQ(x.x_n.y(), y.x_n.y()) << at;
    EXPECT_EQ(x.normalised_ok, y.normalised_ok) << at;
    EXPECT_EQ(x.flux_dn, y.flux_dn) << at;
    EXPECT_EQ(x.background_dn, y.background_dn) << at;
    EXPECT_EQ(x.peak_dn, y.peak_dn) << at;
    EXPECT_EQ(x.area_px, y.area_px) << at;
    EXPECT_EQ(x.saturated_px, y.saturated_px) << at;
    EXPECT_EQ(x.saturated, y.saturated) << at;
    EXPECT_EQ(x.x_min, y.x_min) << at;
    EXPECT_EQ(x.y_min, y.y_min) << at;
    EXPECT_EQ(x.x_max, y.x_max) << at;
    EXPECT_EQ(x.y_max, y.y_max) << at;
    EXPECT_EQ(x.m_xx, y.m_xx) << at;
    EXPECT_EQ(x.m_yy, y.m_yy) << at;
    EXPECT_EQ(x.m_xy, y.m_xy) << at;
    EXPECT_EQ(x.elongation, y.elongation) << at;
  }
  EXPECT_EQ(a.background_dn, b.background_dn) << where;
  EXPECT_EQ(a.noise_dn, b.noise_dn) << where;
  EXPECT_EQ(a.contrast_dn, b.contrast_dn) << where;
  EXPECT_EQ(a.threshold_min_dn, b.threshold_min_dn) << where;
  EXPECT_EQ(a.threshold_max_dn, b.threshold_max_dn) << where;
  EXPECT_EQ(a.blind_cells, b.blind_cells) << where;
  EXPECT_EQ(a.rows_written, b.rows_written) << where;
  const DetectCounters& p = a.counters;
  const DetectCounters& q = b.counters;
  EXPECT_EQ(p.components, q.components) << where;
  EXPECT_EQ(p.rejected_small, q.rejected_small) << where;
  EXPECT_EQ(p.rejected_large, q.rejected_large) << where;
  EXPECT_EQ(p.rejected_border, q.rejected_border) << where;
  EXPECT_EQ(p.rejected_faint, q.rejected_faint) << where;
  EXPECT_EQ(p.rejected_saturated, q.rejected_saturated) << where;
  EXPECT_EQ(p.rejected_elongated, q.rejected_elongated) << where;
  EXPECT_EQ(p.flagged_saturated, q.flagged_saturated) << where;
  EXPECT_EQ(p.over_blob_limit, q.over_blob_limit) << where;
  EXPECT_EQ(p.label_table_full, q.label_table_full) << where;
  EXPECT_EQ(p.open_discarded, q.open_discarded) << where;
  EXPECT_EQ(p.blank_frames, q.blank_frames) << where;
  EXPECT_EQ(p.truncated_frames, q.truncated_frames) << where;
  EXPECT_EQ(p.saturated_frames, q.saturated_frames) << where;
}

// Whether this CPU runs the AVX2 build of the row skip (x86-64 only; detect.cc's CpuHasAvx2).
bool CpuHasAvx2() {
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
  return __builtin_cpu_supports("avx2") != 0;
#else
  return false;
#endif
}

TEST(BlobDetector, FastPathEqualsReference) {
  constexpr int kTrials = 60;
  std::mt19937_64 rng(2012);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  BlobList fast_out, ref_out;
  int blobs = 0, steep = 0, saturated = 0, border = 0, truncated = 0, full = 0;
  for (int trial = 0; trial < kTrials; ++trial) {
    const PixelFormat format = trial % 3 == 2 ? PixelFormat::kMono16 : PixelFormat::kMono8;
    const bool mono8 = format == PixelFormat::kMono8;
    const double scale = mono8 ? 1.0 : 40.0;  // mono16 frames: the same scene at 40x the DN
    const int w = trial % 4 == 0 ? 640 : 100 + static_cast<int>(u01(rng) * 500);
    const int h = trial % 4 == 0 ? 512 : 60 + static_cast<int>(u01(rng) * 300);
    SyntheticImage img(w, h);
    const bool is_steep = trial % 2 == 1;
    steep += is_steep ? 1 : 0;
    const double gx = is_steep ? (u01(rng) - 0.5) * 0.5 : 0.0, gy = is_steep ? (u01(rng) - 0.5) * 0.5 : 0.0;
    img.AddBackground(scale * (60.0 + 30.0 * u01(rng)), scale * gx, scale * gy);
    const int n_spots = 5 + static_cast<int>(u01(rng) * 30);
    for (int i = 0; i < n_spots; ++i) {
      Spot s;
      // Some spots straddle the border (a quarter of them within 3 px of an edge).
      const bool edge = u01(rng) < 0.25;
      s.u = edge ? (u01(rng) < 0.5 ? -1.0 + 4.0 * u01(rng) : w - 3.0 + 4.0 * u01(rng)) : u01(rng) * (w - 1);
      s.v = edge && u01(rng) < 0.5 ? (u01(rng) < 0.5 ? -1.0 + 4.0 * u01(rng) : h - 3.0 + 4.0 * u01(rng))
                                   : u01(rng) * (h - 1);
      border += edge ? 1 : 0;
      s.sigma_x = 0.8 + 2.0 * u01(rng);
      s.sigma_y = s.sigma_x * (0.7 + 0.6 * u01(rng));
      const double peak = u01(rng) < 0.2 ? 400.0 : 8.0 + 150.0 * u01(rng);  // 20 % saturate (> 255)
      saturated += peak > 255.0 ? 1 : 0;
      s.flux = scale * peak * 2.0 * std::numbers::pi * s.sigma_x * s.sigma_y;
      img.AddSpot(s);
    }
    if (trial % 5 == 3) {  // a lamp: a saturated rectangle
      const int x0 = static_cast<int>(u01(rng) * (w - 40)), y0 = static_cast<int>(u01(rng) * (h - 40));
      img.AddRect(x0, y0, x0 + 39, y0 + 39, scale * 300.0);
    }
    img.AddNoise(scale * (0.5 + 3.0 * u01(rng)), rng);
    FrameBuffer fb = Quantize(img, format, trial % 4, mono8 ? 0 : trial % 2);
    if (trial % 7 == 6) {  // truncated: the lower 20 rows never written
      const std::ptrdiff_t offset = fb.view.data - fb.bytes.data();
      for (int y = h - 20; y < h; ++y)
        std::memset(fb.bytes.data() + offset + static_cast<std::ptrdiff_t>(y) * fb.view.stride_bytes, 0,
                    static_cast<std::size_t>(w * BytesPerPixel(format)));
      ++truncated;
    }

    DetectOptions o;
    o.centroid_weights = static_cast<CentroidWeights>(trial % 3);
    o.saturation_policy = static_cast<SaturationPolicy>((trial / 3) % 3);
    o.min_area_px = 1 + trial % 3;
    o.border_margin_px = trial % 4 == 1 ? 2 : 0;
    switch (trial % 6) {
      case 0:
        break;  // defaults
      case 1:
        o.tile_px = 64;
        o.sample_step_px = 4;
        break;  // before issue 20
      case 2:
        o.tile_px = 64;
        o.sample_step_px = 8;
        o.mesh_median_filter = false;
        break;
      case 3:
        o.tile_px = 96;
        o.sample_step_px = 5;
        o.k_sigma = 3.0;
        break;  // thresholds in the noise
      case 4:
        o.threshold_mode = ThresholdMode::kFixed;
        o.fixed_threshold_dn = static_cast<int>(scale * (70.0 + 40.0 * u01(rng)));
        o.fixed_background_dn = scale * 60.0;
        break;
      case 5:
        o.tile_px = 2048;
        break;  // one tile: a flat mesh
    }
    const int labels = trial % 11 == 10 ? 6 : limits::kMaxBlobLabels;  // a tiny table overflows
    full += labels < limits::kMaxBlobLabels ? 1 : 0;
    DetectOptions r = o;
    r.reference_path = true;
    DetectOptions b = o;  // the fast path on baseline vectors only (x86-64: no AVX2)
    b.use_avx2 = false;
    BlobDetector fast(o, labels), ref(r, labels), base(b, labels);
    EXPECT_EQ(fast.vector_bytes(), CpuHasAvx2() ? 32 : 16);  // the AVX2 build runs where it can
    EXPECT_EQ(base.vector_bytes(), 16);
    const std::string where = "trial " + std::to_string(trial);
    const DetectStatus sf = fast.Detect(fb.view, nullptr, &fast_out);
    const DetectStatus sr = ref.Detect(fb.view, nullptr, &ref_out);
    ASSERT_EQ(sf, sr) << where << ": " << ToString(sf) << " / " << ToString(sr);
    ExpectSameBlobList(fast_out, ref_out, where);
    const DetectStatus sb = base.Detect(fb.view, nullptr, &fast_out);
    ASSERT_EQ(sb, sr) << where << " (baseline vectors): " << ToString(sb) << " / " << ToString(sr);
    ExpectSameBlobList(fast_out, ref_out, where + " (baseline vectors)");
    blobs += ref_out.count;
  }
  // The frames did what they were drawn for.
  EXPECT_GT(blobs, 10 * kTrials);
  EXPECT_GT(steep, 0);
  EXPECT_GT(saturated, 0);
  EXPECT_GT(border, 0);
  EXPECT_GT(truncated, 0);
  EXPECT_GT(full, 0);
}

// ---- Issue 20 item 1: windowed detection. Every blob a windowed Detect finds is the one the
// full-frame Detect finds on the same frame, bit for bit (same background and thresholds: the
// whole frame's); every full-frame blob lying inside a window, one pixel clear of its edges, is
// found; a spot a window cuts is rejected and counted, never measured in part. Random frames
// (mono8/mono16, slopes, noise, spots across the borders), windows around some spots (some
// cutting through a spot, some overlapping, some off the frame), plus a stripe; no allocation.
bool Inside(const Blob& b, const PixelWindow& r, int width, int height) {
  // One pixel clear of the window's edges inside the frame (the frame's own edges may be touched).
  return (b.x_min > r.x0 || r.x0 <= 0) && (b.y_min > r.y0 || r.y0 <= 0) && (b.x_max < r.x1 - 1 || r.x1 >= width) &&
         (b.y_max < r.y1 - 1 || r.y1 >= height) && b.x_min >= r.x0 && b.y_min >= r.y0 && b.x_max < r.x1 &&
         b.y_max < r.y1;
}

TEST(BlobDetector, WindowedEqualsFullFrame) {
  std::mt19937_64 rng(4711);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  BlobList full, win;
  int found = 0, cut = 0, expected_inside = 0, overlapping = 0;
  std::uint64_t edge_rejections = 0;
  for (int trial = 0; trial < 30; ++trial) {
    const PixelFormat format = trial % 3 == 2 ? PixelFormat::kMono16 : PixelFormat::kMono8;
    const double scale = format == PixelFormat::kMono8 ? 1.0 : 40.0;
    const int w = 320 + static_cast<int>(u01(rng) * 400), h = 240 + static_cast<int>(u01(rng) * 300);
    SyntheticImage img(w, h);
    img.AddBackground(scale * 30.0, scale * (u01(rng) - 0.5) * 0.2, scale * (u01(rng) - 0.5) * 0.2);
    std::vector<Spot> spots;
    for (int i = 0; i < 20; ++i) {
      Spot sp;
      sp.u = -2.0 + u01(rng) * (w + 3);
      sp.v = -2.0 + u01(rng) * (h + 3);
      sp.sigma_x = sp.sigma_y = 1.0 + 1.5 * u01(rng);
      sp.flux = scale * (40.0 + 300.0 * u01(rng)) * 2.0 * std::numbers::pi * sp.sigma_x * sp.sigma_y;
      img.AddSpot(sp);
      spots.push_back(sp);
    }
    img.AddNoise(scale * 2.0, rng);
    const FrameBuffer fb = Quantize(img, format, trial % 3);
    std::vector<PixelWindow> windows;
    for (std::size_t i = 0; i < spots.size(); i += 2) {
      const Spot& sp = spots[i];
      // Half-size from 2 px (cuts the spot) to 14 px; shifted off centre by up to 3 px.
      const int half = 2 + static_cast<int>(u01(rng) * 12);
      const int cx = static_cast<int>(sp.u + 6.0 * (u01(rng) - 0.5)),
                cy = static_cast<int>(sp.v + 6.0 * (u01(rng) - 0.5));
      windows.push_back(PixelWindow{cx - half, cy - half, cx + half + 1, cy + half + 1});
    }
    windows.push_back(DetectionStripe(w, h, trial, 8, 16));
    windows.push_back(PixelWindow{w - 30, h - 30, w + 50, h + 50});  // partly off the frame
    DetectOptions o;
    o.centroid_weights = static_cast<CentroidWeights>(trial % 3);
    if (trial % 4 == 3) {
      o.threshold_mode = ThresholdMode::kFixed;
      o.fixed_threshold_dn = static_cast<int>(scale * 45.0);
      o.fixed_background_dn = scale * 30.0;
    }
    BlobDetector d(o);
    const std::string where = "trial " + std::to_string(trial);
    ASSERT_EQ(d.Detect(fb.view, nullptr, &full), DetectStatus::kOk) << where;
    const long news_before = g_news.load();
    const DetectStatus s = d.Detect(fb.view, nullptr, windows.data(), static_cast<int>(windows.size()), &win);
    EXPECT_EQ(g_news.load(), news_before) << where;
    ASSERT_TRUE(s == DetectStatus::kOk || s == DetectStatus::kBlankFrame) << where << " " << ToString(s);
    EXPECT_EQ(win.counters.windows_dropped, 0u) << where;
    EXPECT_EQ(win.background_dn, full.background_dn) << where;
    EXPECT_EQ(win.noise_dn, full.noise_dn) << where;
    edge_rejections += win.counters.rejected_window_edge;
    // Every windowed blob is a full-frame blob, bit for bit.
    for (std::size_t i = 0; i < static_cast<std::size_t>(win.count); ++i) {
      const Blob& b = win.blobs[i];
      bool same = false;
      for (std::size_t j = 0; j < static_cast<std::size_t>(full.count) && !same; ++j) {
        const Blob& f = full.blobs[j];
        same = f.uv_px == b.uv_px && f.flux_dn == b.flux_dn && f.background_dn == b.background_dn &&
               f.peak_dn == b.peak_dn && f.area_px == b.area_px && f.m_xx == b.m_xx && f.m_yy == b.m_yy &&
               f.m_xy == b.m_xy && f.elongation == b.elongation && f.x_min == b.x_min && f.y_max == b.y_max;
      }
      EXPECT_TRUE(same) << where << " windowed blob " << i << " at " << b.uv_px.transpose();
      ++found;
    }
    // Every full-frame blob clear inside a window is found.
    for (std::size_t j = 0; j < static_cast<std::size_t>(full.count); ++j) {
      const Blob& f = full.blobs[j];
      bool inside = false;
      int containing = 0;
      for (const PixelWindow& r : windows) {
        const bool in = Inside(f, r, w, h);
        inside = inside || in;
        containing += f.x_max >= r.x0 && f.x_min < r.x1 && f.y_max >= r.y0 && f.y_min < r.y1 ? 1 : 0;
      }
      overlapping += containing > 1 ? 1 : 0;
      if (!inside) {
        ++cut;
        continue;
      }
      ++expected_inside;
      bool hit = false;
      for (std::size_t i = 0; i < static_cast<std::size_t>(win.count) && !hit; ++i) hit = win.blobs[i].uv_px == f.uv_px;
      EXPECT_TRUE(hit) << where << " full-frame blob at " << f.uv_px.transpose() << " inside a window not found";
    }
  }
  EXPECT_GT(found, 100);
  EXPECT_GT(expected_inside, 100);
  EXPECT_GT(cut, 10);              // blobs outside the windows or cut by one
  EXPECT_GT(edge_rejections, 5u);  // windows cutting through spots were rejected, not measured
  EXPECT_GT(overlapping, 0);
}

TEST(BlobDetector, WindowsOverTheLimitOrEmptyAreDroppedAndCounted) {
  SyntheticImage img(200, 100);
  img.AddBackground(20.0);
  std::mt19937_64 rng(3);
  img.AddNoise(2.0, rng);
  const FrameBuffer fb = Quantize(img, PixelFormat::kMono8);
  std::vector<PixelWindow> windows(static_cast<std::size_t>(limits::kMaxDetectWindows) + 5,
                                   PixelWindow{10, 10, 20, 20});
  windows[0] = PixelWindow{300, 0, 400, 50};  // outside the frame
  windows[1] = PixelWindow{50, 50, 50, 60};   // empty
  BlobDetector d;
  BlobList out;
  d.Detect(fb.view, nullptr, windows.data(), static_cast<int>(windows.size()), &out);
  EXPECT_EQ(out.counters.windows_dropped, 7u);
  EXPECT_EQ(d.counters().windows_dropped, 7u);
}

// DetectionStripe: N stripes cover every row; a blob at most `margin` rows tall lies inside the
// stripe of its top row, clear of its edges; and the stated bound, simulated: a static blob is
// inside the stripe of some frame set among any N consecutive ones, a blob moving by less than
// 2 margin - height rows per frame set within 2N - 1.
TEST(DetectionStripe, CoversEveryRowAndBoundsTheTimeToFindABlob) {
  constexpr int kW = 1280, kH = 1024, kN = 8, kMargin = 24;
  std::vector<int> covered(kH, 0);
  for (int k = 0; k < kN; ++k) {
    const PixelWindow s = DetectionStripe(kW, kH, k, kN, kMargin);
    EXPECT_EQ(s.x0, 0);
    EXPECT_EQ(s.x1, kW);
    for (int y = s.y0; y < s.y1; ++y) covered[static_cast<std::size_t>(y)] = 1;
    EXPECT_EQ(DetectionStripe(kW, kH, k + 3 * kN, kN, kMargin).y0, s.y0);  // periodic
  }
  for (int y = 0; y < kH; ++y) ASSERT_EQ(covered[static_cast<std::size_t>(y)], 1) << y;
  // Inside stripe k, clear of its inner edges (the windowed Detect's rule).
  const auto clear = [&](int k, int top, int height) {
    const PixelWindow s = DetectionStripe(kW, kH, k, kN, kMargin);
    return top >= s.y0 && top + height <= s.y1 && (top > s.y0 || s.y0 == 0) && (top + height < s.y1 || s.y1 == kH);
  };
  for (int height = 1; height <= kMargin; height += 7) {
    for (int top = 0; top + height <= kH; ++top) {
      bool any = false;
      for (int k = 0; k < kN; ++k) any = any || clear(k, top, height);
      ASSERT_TRUE(any) << "height " << height << " top " << top;
    }
  }
  const int height = 8;
  int worst_static = 0, worst_moving = 0;
  for (int speed = -(2 * kMargin - height - 1); speed <= 2 * kMargin - height - 1; speed += 3) {
    for (int start = 0; start < kH - height; start += 13) {
      for (int phase = 0; phase < kN; ++phase) {
        int found_after = -1;
        for (int t = 0; t < 4 * kN && found_after < 0; ++t) {
          const int top = start + speed * t;
          if (top < 0 || top + height > kH) break;  // left the frame
          if (clear(phase + t, top, height)) found_after = t;
        }
        const int last_top = start + speed * (2 * kN - 2);
        if (last_top < 0 || last_top + height > kH) continue;  // leaves the frame before the bound
        ASSERT_GE(found_after, 0) << "speed " << speed << " start " << start << " phase " << phase;
        (speed == 0 ? worst_static : worst_moving) = std::max(speed == 0 ? worst_static : worst_moving, found_after);
      }
    }
  }
  EXPECT_LE(worst_static, kN - 1);
  EXPECT_LE(worst_moving, 2 * kN - 2);
}

// ---- No heap after construction: 100 frames (mono8 and mono16, adaptive and fixed, with
// undistortion) detected with zero calls to operator new.
TEST(BlobDetector, NoAllocationWhileDetecting) {
  // Camera y of the paper rig at half resolution (640 x 512) to keep the test fast under qemu.
  CameraIntrinsics cam = PaperRig().cameras[1].intrinsics;
  cam.width /= 2;
  cam.height /= 2;
  cam.alpha_x /= 2;
  cam.alpha_y /= 2;
  cam.u0 = 0.5 * (cam.u0 + 0.5) - 0.5;  // pixel centres at integers
  cam.v0 = 0.5 * (cam.v0 + 0.5) - 0.5;
  std::mt19937_64 rng(23);
  std::vector<FrameBuffer> frames;
  for (int i = 0; i < 4; ++i) {
    const std::vector<Spot> spots = GridSpots(cam.width, cam.height, 4, 3, i < 2 ? 150.0 : 30000.0, rng);
    SyntheticImage img(cam.width, cam.height);
    img.AddBackground(i < 2 ? 10.0 : 600.0);
    for (const Spot& s : spots) img.AddSpot(s);
    img.AddNoise(i < 2 ? 2.0 : 50.0, rng);
    frames.push_back(Quantize(img, i < 2 ? PixelFormat::kMono8 : PixelFormat::kMono16, 8 * i));
  }
  DetectOptions fixed;
  fixed.threshold_mode = ThresholdMode::kFixed;
  fixed.fixed_threshold_dn = 60;
  BlobDetector adaptive;
  BlobDetector fixed_detector(fixed);
  BlobList out;

  const long before = g_news.load();
  int total = 0;
  for (int f = 0; f < 100; ++f) {
    const FrameBuffer& fb = frames[static_cast<std::size_t>(f) % frames.size()];
    BlobDetector& d = (f % 5 == 4 && fb.view.format == PixelFormat::kMono8) ? fixed_detector : adaptive;
    const DetectStatus s = d.Detect(fb.view, &cam, &out);
    total += s == DetectStatus::kOk ? out.count : 0;
  }
  const long after = g_news.load();
  EXPECT_EQ(after - before, 0);
  EXPECT_EQ(total, 100 * 12);  // it really detected
  // The counter itself works: a vector allocates.
  std::vector<int>* v = new std::vector<int>(10);
  EXPECT_GT(g_news.load(), after);
  delete v;
}

}  // namespace
}  // namespace mfns::fw
