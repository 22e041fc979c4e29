// Independent reference (host only): OpenCV's threshold + connectedComponentsWithStats and an
// intensity-weighted centroid over each component must give the detector's blob set and
// centroids on random multi-spot images.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "firmware/modules/detect/detect.h"
#include "firmware/modules/detect/detect_testing.h"

namespace mfns::fw {
namespace {

using testing::FrameBuffer;
using testing::Quantize;
using testing::Spot;
using testing::SyntheticImage;

struct CvBlob {
  int x_min, y_min, x_max, y_max, area;
  double u, v, flux;
  int peak;
};

// threshold (pixel > t) -> 8-connected components -> weighted centroid per component with
// weights max(pixel - background, 0) (or the raw pixel).
std::vector<CvBlob> ReferenceBlobs(const FrameView& f, int threshold, double background,
                                    bool subtract) {
  const int type = f.format == PixelFormat::kMono8 ? CV_8UC1 : CV_16UC1;
  const cv::Mat img(f.height, f.width, type, const_cast<std::uint8_t*>(f.data),
                    static_cast<std::size_t>(f.stride_bytes));
  cv::Mat mask;
  cv::threshold(img, mask, threshold, 255, cv::THRESH_BINARY);
  if (mask.type() != CV_8UC1) mask.convertTo(mask, CV_8UC1);  // 255 saturates: still 255
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  std::vector<CvBlob> out;
  for (int l = 1; l < n; ++l) {
    CvBlob b{};
    b.x_min = stats.at<int>(l, cv::CC_STAT_LEFT);
    b.y_min = stats.at<int>(l, cv::CC_STAT_TOP);
    b.x_max = b.x_min + stats.at<int>(l, cv::CC_STAT_WIDTH) - 1;
    b.y_max = b.y_min + stats.at<int>(l, cv::CC_STAT_HEIGHT) - 1;
    b.area = stats.at<int>(l, cv::CC_STAT_AREA);
    double s0 = 0.0, sx = 0.0, sy = 0.0;
    for (int y = b.y_min; y <= b.y_max; ++y) {
      for (int x = b.x_min; x <= b.x_max; ++x) {
        if (labels.at<int>(y, x) != l) continue;
        const int p = f.format == PixelFormat::kMono8 ? img.at<std::uint8_t>(y, x) : img.at<std::uint16_t>(y, x);
        const double w = subtract ? std::max(p - background, 0.0) : p;
        s0 += w;
        sx += w * x;
        sy += w * y;
        b.peak = std::max(b.peak, p);
      }
    }
    b.u = sx / s0;
    b.v = sy / s0;
    b.flux = s0;
    out.push_back(b);
  }
  return out;
}

DetectOptions PermissiveFixed(int threshold, double background, bool subtract) {
  DetectOptions o;
  o.threshold_mode = ThresholdMode::kFixed;
  o.fixed_threshold_dn = threshold;
  o.fixed_background_dn = background;
  o.centroid_weights = subtract ? CentroidWeights::kAboveBackground : CentroidWeights::kRaw;
  o.min_area_px = 1;
  o.max_area_px = 1 << 30;
  o.reject_border = false;
  o.min_peak_above_background_dn = 0.0;
  o.saturation_policy = SaturationPolicy::kAccept;
  o.max_elongation = 1e9;
  return o;
}

struct Case {
  PixelFormat format;
  bool subtract;
};

class OpenCvReference : public ::testing::TestWithParam<Case> {};

TEST_P(OpenCvReference, SameComponentsAndCentroidsOnRandomMultiSpotImages) {
  const Case c = GetParam();
  const bool mono8 = c.format == PixelFormat::kMono8;
  const double scale = mono8 ? 1.0 : 200.0;  // mono16 spans a larger range
  const double background = 20.0 * scale;
  const int threshold = static_cast<int>(45.0 * scale);
  std::mt19937_64 rng(mono8 ? 101 : 202);
  std::uniform_real_distribution<double> ux(2.0, 637.0), uy(2.0, 477.0), us(0.7, 3.0), up(30.0, 250.0);
  std::uniform_int_distribution<int> count(5, 60);
  BlobDetector detector(PermissiveFixed(threshold, c.subtract ? background : 0.0, c.subtract));
  BlobList out;
  int total = 0;
  for (int trial = 0; trial < 20; ++trial) {
    SyntheticImage img(640, 480);
    img.AddBackground(background);
    const int n = count(rng);
    for (int i = 0; i < n; ++i) {  // overlaps and border contacts happen: both must agree
      Spot s;
      s.u = ux(rng);
      s.v = uy(rng);
      s.sigma_x = us(rng);
      s.sigma_y = s.sigma_x * (0.6 + 0.8 * (us(rng) - 0.7) / 2.3);
      s.flux = up(rng) * scale * 2.0 * std::numbers::pi * s.sigma_x * s.sigma_y;
      img.AddSpot(s);
    }
    img.AddNoise(3.0 * scale, rng);
    const FrameBuffer fb = Quantize(img, c.format, 5 * (trial % 3) * (mono8 ? 1 : 2));

    const std::vector<CvBlob> ref = ReferenceBlobs(fb.view, threshold, background, c.subtract);
    ASSERT_LE(ref.size(), static_cast<std::size_t>(limits::kMaxBlobsPerFrame));
    ASSERT_EQ(detector.Detect(fb.view, nullptr, &out), DetectStatus::kOk);
    ASSERT_EQ(out.count, static_cast<int>(ref.size())) << "trial " << trial;
    std::vector<int> used(ref.size(), 0);
    for (std::size_t i = 0; i < static_cast<std::size_t>(out.count); ++i) {
      const Blob& b = out.blobs[i];
      std::size_t match = ref.size();
      for (std::size_t r = 0; r < ref.size() && match == ref.size(); ++r)
        if (!used[r] && ref[r].x_min == b.x_min && ref[r].y_min == b.y_min &&
            ref[r].x_max == b.x_max && ref[r].y_max == b.y_max && ref[r].area == b.area_px)
          match = r;
      ASSERT_LT(match, ref.size()) << "trial " << trial << ": no OpenCV component with blob " << i << "'s box";
      used[match] = 1;
      EXPECT_NEAR(b.uv_px.x(), ref[match].u, 1e-6);
      EXPECT_NEAR(b.uv_px.y(), ref[match].v, 1e-6);
      EXPECT_NEAR(b.flux_dn, ref[match].flux, 1e-9 * ref[match].flux);
      EXPECT_EQ(b.peak_dn, ref[match].peak);
    }
    total += out.count;
  }
  EXPECT_GT(total, 20 * 10);  // the images really had many components
}

INSTANTIATE_TEST_SUITE_P(Formats, OpenCvReference,
                         ::testing::Values(Case{PixelFormat::kMono8, true}, Case{PixelFormat::kMono8, false},
                                           Case{PixelFormat::kMono16, true}, Case{PixelFormat::kMono16, false}),
                         [](const ::testing::TestParamInfo<Case>& p) {
                           return std::string(p.param.format == PixelFormat::kMono8 ? "Mono8" : "Mono16") +
                                  (p.param.subtract ? "AboveBackground" : "Raw");
                         });

}  // namespace
}  // namespace mfns::fw
