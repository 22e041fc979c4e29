#include "host/sim/render/spot.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "common/rig/paper_rig.h"

namespace mfns::host {
namespace {

// Plain intensity-weighted centroid of (image - background) over a square window around guess.
Eigen::Vector2d Centroid(const cv::Mat& image, const Eigen::Vector2d& guess, int radius, double background) {
  const int cu = static_cast<int>(std::lround(guess.x())), cv = static_cast<int>(std::lround(guess.y()));
  double sum = 0.0, su = 0.0, sv = 0.0;
  for (int v = std::max(0, cv - radius); v <= std::min(image.rows - 1, cv + radius); ++v) {
    for (int u = std::max(0, cu - radius); u <= std::min(image.cols - 1, cu + radius); ++u) {
      const double value = image.type() == CV_8UC1 ? image.at<unsigned char>(v, u)
                           : image.type() == CV_16UC1 ? image.at<std::uint16_t>(v, u)
                                                      : image.at<double>(v, u);
      const double w = value - background;
      sum += w;
      su += w * u;
      sv += w * v;
    }
  }
  return {su / sum, sv / sum};
}

// Pixels spread over the whole image: centre, corners and edge midpoints 12 px inside the
// border, each with a fractional offset.
std::vector<Eigen::Vector2d> TestPixels(const CameraIntrinsics& cam, std::mt19937_64* rng) {
  std::vector<Eigen::Vector2d> out;
  const double w = cam.width - 1, h = cam.height - 1, m = 12.0;
  for (double fu : {0.0, 0.5, 1.0})
    for (double fv : {0.0, 0.5, 1.0})
      out.emplace_back(m + fu * (w - 2 * m) + Uniform01(rng) - 0.5, m + fv * (h - 2 * m) + Uniform01(rng) - 0.5);
  return out;
}

// A beacon at depth_m on the ray of pixel uv.
Eigen::Vector3d BeaconOnRay(const CameraIntrinsics& cam, const Eigen::Vector2d& uv, double depth_m) {
  Eigen::Vector2d x_n;
  EXPECT_EQ(Unproject(cam, uv, &x_n), UnprojectStatus::kOk);
  return depth_m * Eigen::Vector3d(x_n.x(), x_n.y(), 1.0);
}

TEST(GaussianSpot, MatchesDenseSupersamplingAndConservesFlux) {
  // Reference: the Gaussian density point-sampled 40x40 times per pixel (written differently
  // from the erf integration of the renderer).
  cv::Mat signal(21, 21, CV_64FC1, cv::Scalar(0.0));
  const GaussianSpot spot{{10.3, 9.8}, 1.1, 5000.0};
  AddGaussianSpot(spot, &signal);
  double total = 0.0, max_error = 0.0;
  constexpr int kSub = 40;
  for (int v = 0; v < signal.rows; ++v) {
    for (int u = 0; u < signal.cols; ++u) {
      double reference = 0.0;
      for (int j = 0; j < kSub; ++j) {
        for (int i = 0; i < kSub; ++i) {
          const double du = u - 0.5 + (i + 0.5) / kSub - spot.uv_px.x();
          const double dv = v - 0.5 + (j + 0.5) / kSub - spot.uv_px.y();
          reference += std::exp(-(du * du + dv * dv) / (2 * spot.sigma_px * spot.sigma_px));
        }
      }
      reference *= spot.flux_e / (2 * 3.14159265358979 * spot.sigma_px * spot.sigma_px) / (kSub * kSub);
      max_error = std::max(max_error, std::abs(reference - signal.at<double>(v, u)));
      total += signal.at<double>(v, u);
    }
  }
  EXPECT_LT(max_error, 1e-3 * spot.flux_e / 10);  // midpoint rule error is O(1/kSub^2)
  EXPECT_NEAR(total, spot.flux_e, 1e-9 * spot.flux_e);
}

TEST(GaussianSpot, PeakHelperGivesThePeakPixel) {
  cv::Mat signal(15, 15, CV_64FC1, cv::Scalar(0.0));
  AddGaussianSpot({{7.0, 7.0}, 1.3, FluxForPeak(200.0, 1.3)}, &signal);
  double peak = 0.0;
  cv::minMaxLoc(signal, nullptr, &peak);
  EXPECT_NEAR(peak, 200.0, 1e-9);
  EXPECT_NEAR(signal.at<double>(7, 7), 200.0, 1e-9);
}

TEST(GaussianSpot, RejectsBadInput) {
  cv::Mat signal(8, 8, CV_64FC1, cv::Scalar(0.0));
  EXPECT_THROW(AddGaussianSpot({{3, 3}, 0.0, 10.0}, &signal), std::invalid_argument);
  EXPECT_THROW(AddGaussianSpot({{3, 3}, 1.0, -1.0}, &signal), std::invalid_argument);
  EXPECT_THROW(AddGaussianSpot({{NAN, 3}, 1.0, 1.0}, &signal), std::invalid_argument);
  cv::Mat wrong(8, 8, CV_8UC1);
  EXPECT_THROW(AddGaussianSpot({{3, 3}, 1.0, 1.0}, &wrong), std::invalid_argument);
  // A spot far outside the image adds nothing and does not fail, however far.
  AddGaussianSpot({{-100.0, 4.0}, 1.0, 1e6}, &signal);
  AddGaussianSpot({{1e300, -1e300}, 1.0, 1e6}, &signal);
  EXPECT_EQ(cv::countNonZero(signal), 0);
  EXPECT_THROW(AddBrightRectangle({0.0, 0.0, INFINITY, 3.0, 1.0}, &signal), std::invalid_argument);
  EXPECT_THROW(AddBrightEllipse({{3.0, 3.0}, 0.0, 2.0, 0.0, 1.0}, &signal), std::invalid_argument);
  // A window larger than the image covers it all.
  AddBrightRectangle({-1e300, -1e300, 1e300, 1e300, 2.0}, &signal);
  EXPECT_EQ(cv::sum(signal)[0], 2.0 * 64);
}

// The requirement: at zero noise the plain centroid of a rendered beacon lands within
// 0.05 px of the true centre (the projected beacon), across the image, with each paper
// camera's distortion, in mono8 and mono16.
TEST(LedFrame, CentroidOfEveryBeaconWithinFiveHundredthsOfAPixelAtZeroNoise) {
  const Rig rig = PaperRig();
  std::mt19937_64 rng(7);
  for (int bits : {8, 16}) {
    double worst = 0.0;
    for (int k = 0; k < rig.num_cameras; ++k) {
      const CameraIntrinsics& cam = rig.cameras[static_cast<std::size_t>(k)].intrinsics;
      LedFrameSpec spec;
      spec.background_e = 10.0;  // a whole number of DN: no rounding left far from the spots
      const std::vector<Eigen::Vector2d> pixels = TestPixels(cam, &rng);
      for (std::size_t i = 0; i < pixels.size(); ++i) {
        BeaconInView b;
        b.id = static_cast<int>(i);
        b.p_k = BeaconOnRay(cam, pixels[i], 1.0 + 0.3 * static_cast<double>(i));
        b.appearance.sigma_px = 1.0 + 0.1 * static_cast<double>(i % 4);
        b.appearance.flux_e = FluxForPeak(bits == 8 ? 200.0 : 3000.0, b.appearance.sigma_px);
        spec.beacons.push_back(b);
      }
      const SensorModel sensor = SensorModel::Noiseless(bits, bits == 8 ? 1.0 : 16.0);
      const LedFrame frame = RenderLedFrame(cam, spec, sensor, nullptr);
      ASSERT_EQ(frame.truth.size(), pixels.size());
      for (std::size_t i = 0; i < pixels.size(); ++i) {
        const BeaconTruth& t = frame.truth[i];
        ASSERT_TRUE(t.projection.visible) << "camera " << k << " beacon " << i;
        // Truth is the distorted projection, which here is the chosen pixel.
        EXPECT_LT((t.projection.uv_px - pixels[i]).norm(), 1e-6);
        const Eigen::Vector2d c = Centroid(frame.image, t.projection.uv_px, 7, spec.background_e * sensor.gain_dn_per_e);
        worst = std::max(worst, (c - t.projection.uv_px).norm());
        EXPECT_LT((c - t.projection.uv_px).norm(), 0.05)
            << bits << "-bit camera " << k << " beacon " << i << " at " << t.projection.uv_px.transpose();
      }
      // The corners are far from where a pinhole camera would put them: distortion matters.
      const Eigen::Vector3d& corner = spec.beacons[0].p_k;
      const Eigen::Vector2d pinhole(cam.alpha_x * corner.x() / corner.z() + cam.u0,
                                    cam.alpha_y * corner.y() / corner.z() + cam.v0);
      EXPECT_GT((pinhole - frame.truth[0].projection.uv_px).norm(), 5.0) << "camera " << k;
    }
    std::printf("%d-bit worst centroid error %.4f px\n", bits, worst);
  }
}

TEST(LedFrame, CentroidIsUnbiasedAtEverySubpixelPhase) {
  // Signal level (no quantisation): the pixel-integrated Gaussian keeps its centroid exact.
  CameraIntrinsics cam = PaperRig().cameras[0].intrinsics;
  for (int i = 0; i < 25; ++i) {
    cv::Mat signal(cam.height, cam.width, CV_64FC1, cv::Scalar(0.0));
    const Eigen::Vector2d uv(600.0 + 0.2 * (i % 5) + 0.013, 500.0 + 0.2 * (i / 5) + 0.007);
    AddGaussianSpot({uv, 0.8, 1000.0}, &signal);
    EXPECT_LT((Centroid(signal, uv, 9, 0.0) - uv).norm(), 1e-3) << uv.transpose();
  }
}

TEST(LedFrame, BehindTheCameraOrOutsideIsNotVisibleAndNotDrawn) {
  const CameraIntrinsics cam = PaperRig().cameras[1].intrinsics;
  LedFrameSpec spec;
  spec.background_e = 0.0;
  spec.beacons.push_back({1, Eigen::Vector3d(0.0, 0.0, -2.0), {}});             // behind
  spec.beacons.push_back({2, Eigen::Vector3d(3.0, 0.0, 1.0), {}});              // far outside
  spec.beacons.push_back({3, BeaconOnRay(cam, {2.0, 500.0}, 2.0), {}});         // inside, near the edge
  spec.margin_px = 5.0;
  std::vector<BeaconTruth> truth;
  const cv::Mat signal = RenderLedSignal(cam, spec, &truth);
  ASSERT_EQ(truth.size(), 3u);
  EXPECT_EQ(truth[0].projection.status, ProjectStatus::kBehindCamera);
  EXPECT_FALSE(truth[0].projection.visible);
  EXPECT_FALSE(truth[1].projection.visible);
  EXPECT_FALSE(truth[2].projection.visible);  // within the 5 px margin
  // Only beacon 3 (partly in the image) put light in the frame.
  EXPECT_GT(cv::sum(signal)[0], 0.4 * spec.beacons[2].appearance.flux_e);
  EXPECT_LT(cv::sum(signal)[0], spec.beacons[2].appearance.flux_e);
  EXPECT_EQ(truth[2].id, 3);
}

TEST(LedFrame, ClutterAddsExactlyTheRequestedLight) {
  CameraIntrinsics cam;
  cam.width = 64;
  cam.height = 48;
  cam.alpha_x = cam.alpha_y = 50.0;
  cam.u0 = 31.5;
  cam.v0 = 23.5;
  LedFrameSpec spec;
  spec.background_e = 0.0;
  spec.rectangles.push_back({10.25, 5.5, 20.75, 12.0, 100.0});  // 10.5 x 6.5 px
  cv::Mat signal = RenderLedSignal(cam, spec);
  EXPECT_NEAR(cv::sum(signal)[0], 100.0 * 10.5 * 6.5, 1e-9);
  EXPECT_DOUBLE_EQ(signal.at<double>(8, 15), 100.0);   // fully inside
  EXPECT_DOUBLE_EQ(signal.at<double>(8, 10), 25.0);    // u = 10 covers [10.25, 10.5]
  EXPECT_DOUBLE_EQ(signal.at<double>(4, 15), 0.0);

  spec.rectangles.clear();
  spec.ellipses.push_back({{30.2, 20.1}, 12.0, 6.0, 0.4, 50.0});
  signal = RenderLedSignal(cam, spec);
  EXPECT_NEAR(cv::sum(signal)[0], 50.0 * 3.14159265358979 * 12.0 * 6.0, 0.01 * 50.0 * 226.0);
  EXPECT_DOUBLE_EQ(signal.at<double>(20, 30), 50.0);
  // The rotated ellipse: along its major axis (0.4 rad) it reaches 12 px, across only 6.
  EXPECT_GT(signal.at<double>(static_cast<int>(std::lround(20.1 + 10 * std::sin(0.4))),
                              static_cast<int>(std::lround(30.2 + 10 * std::cos(0.4)))), 0.0);
  EXPECT_EQ(signal.at<double>(static_cast<int>(std::lround(20.1 + 10 * std::cos(0.4))),
                              static_cast<int>(std::lround(30.2 - 10 * std::sin(0.4)))), 0.0);

  spec.ellipses.clear();
  spec.reflections.push_back({{20.0, 20.0}, 1.0, 700.0});
  signal = RenderLedSignal(cam, spec);
  EXPECT_NEAR(cv::sum(signal)[0], 700.0, 1e-6);
  EXPECT_LT((Centroid(signal, {20.0, 20.0}, 8, 0.0) - Eigen::Vector2d(20.0, 20.0)).norm(), 1e-6);
}

TEST(LedFrame, BlankFrameIsAllZeroWithNoTruth) {
  const CameraIntrinsics cam = PaperRig().cameras[2].intrinsics;
  LedFrameSpec spec;
  spec.blank = true;
  spec.beacons.push_back({0, Eigen::Vector3d(0.0, 0.0, 2.0), {}});
  SensorModel sensor;
  sensor.offset_dn = 5.0;
  sensor.read_noise_e = 3.0;
  std::mt19937_64 rng(1);
  const LedFrame frame = RenderLedFrame(cam, spec, sensor, &rng);
  EXPECT_EQ(frame.image.type(), CV_8UC1);
  EXPECT_EQ(frame.image.cols, cam.width);
  EXPECT_EQ(cv::countNonZero(frame.image), 0);
  EXPECT_TRUE(frame.truth.empty());
}

TEST(LedFrame, SaturatedSpotClipsAtFullScale) {
  const CameraIntrinsics cam = PaperRig().cameras[0].intrinsics;
  LedFrameSpec spec;
  spec.beacons.push_back({0, Eigen::Vector3d(0.01, 0.02, 2.0), {1.5, FluxForPeak(1000.0, 1.5)}});
  const LedFrame frame = RenderLedFrame(cam, spec, SensorModel::Noiseless(8), nullptr);
  double peak = 0.0;
  cv::minMaxLoc(frame.image, nullptr, &peak);
  EXPECT_EQ(peak, 255.0);
  // Clipping is symmetric about the centre here, so even the saturated centroid holds.
  const Eigen::Vector2d c = Centroid(frame.image, frame.truth[0].projection.uv_px, 9, spec.background_e);
  EXPECT_LT((c - frame.truth[0].projection.uv_px).norm(), 0.1);
}

}  // namespace
}  // namespace mfns::host
