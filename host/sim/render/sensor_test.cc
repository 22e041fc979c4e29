#include "host/sim/render/sensor.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <vector>

#include "common/rig/paper_rig.h"
#include "host/sim/render/spot.h"
#include "host/sim/render/target_renderer.h"

namespace mfns::host {
namespace {

struct Moments {
  double mean = 0.0, variance = 0.0;
};

Moments ImageMoments(const cv::Mat& image) {
  cv::Mat as_double;
  image.convertTo(as_double, CV_64F);
  cv::Scalar mean, stddev;
  cv::meanStdDev(as_double, mean, stddev);
  const double n = static_cast<double>(image.total());
  return {mean[0], stddev[0] * stddev[0] * n / (n - 1)};
}

// Sampling tolerance: k standard errors of the mean and of the variance for n draws
// (the variance's standard error is var * sqrt(2 / (n - 1)) for near-normal data).
void ExpectMoments(const Moments& m, double mean, double variance, double n, const char* what) {
  const double k = 5.0;
  EXPECT_NEAR(m.mean, mean, k * std::sqrt(variance / n)) << what;
  EXPECT_NEAR(m.variance, variance, k * variance * std::sqrt(2.0 / (n - 1))) << what;
}

// One sensor regime of the tests below.
struct SensorCase {
  double signal_e, gain, offset, read_e, full_well;
  bool shot;
  int bits;
  SensorModel Model() const {
    SensorModel s;
    s.bit_depth = bits;
    s.gain_dn_per_e = gain;
    s.offset_dn = offset;
    s.read_noise_e = read_e;
    s.full_well_e = full_well;
    s.shot_noise = shot;
    return s;
  }
};

constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(Sensor, FlatFieldMatchesThePhotonTransferModel) {
  // Three regimes of the model: Poisson + read noise (PTRS path, 16 bit), a faint field
  // (inversion path, 16 bit) and read noise only (8 bit). Expected DN variance is
  // g^2 (s + r^2) + 1/12 from rounding.
  const SensorCase cases[] = {{400.0, 2.0, 100.0, 3.0, kInf, true, 16},
                              {3.5, 8.0, 50.0, 0.0, kInf, true, 16},
                              {0.0, 1.0, 60.0, 4.0, kInf, false, 8}};
  std::mt19937_64 rng(2024);
  for (const SensorCase& c : cases) {
    const SensorModel s = c.Model();
    const cv::Mat signal(256, 256, CV_64FC1, cv::Scalar(c.signal_e));
    const cv::Mat image = ApplySensor(signal, s, &rng);
    ASSERT_EQ(image.type(), c.bits == 8 ? CV_8UC1 : CV_16UC1);
    const double shot_var = c.shot ? c.signal_e : 0.0;
    ExpectMoments(ImageMoments(image), c.offset + c.gain * c.signal_e,
                  c.gain * c.gain * (shot_var + c.read_e * c.read_e) + 1.0 / 12.0,
                  static_cast<double>(image.total()), "flat field");
  }
}

// One pixel of the model as sensor.h defines it, composed of the public samplers: the reference
// for the tabulated law of a level.
int ModelPixel(double signal_e, const SensorModel& s, PoissonSampler* poisson, NormalSampler* normal,
               std::mt19937_64* rng) {
  double e = std::max(0.0, signal_e);
  if (s.shot_noise) e = static_cast<double>(poisson->Draw(e, rng));
  e = std::min(e, s.full_well_e);
  if (s.read_noise_e > 0.0) e += s.read_noise_e * normal->Draw(rng);
  return static_cast<int>(std::clamp(std::nearbyint(s.offset_dn + s.gain_dn_per_e * e), 0.0, double(s.FullScale())));
}

// The tabulated law of a level (what ApplySensor draws a frame's background from) is the
// model's: over shot/read noise regimes, gains below and above 1, offsets, a full well, both
// clamps, each DN's probability is within 5 standard errors of its frequency in 200000
// pixel-by-pixel draws, and so is the frequency of the table's own draws. Closed forms where
// they exist: read noise only (a rounded normal) and shot noise only at gain 1 (Poisson).
TEST(Sensor, LevelDistributionIsTheModelsLaw) {
  const double inf = kInf;
  const SensorCase cases[] = {{8.0, 1.0, 0.0, 2.0, inf, true, 8},     {150.0, 0.6, 3.2, 2.0, inf, true, 8},
                              {0.3, 3.7, 10.0, 0.4, inf, true, 16},   {0.0, 1.0, 0.0, 2.0, inf, true, 8},
                              {40.0, 2.0, 200.0, 1.0, 30.0, true, 8}, {6.0, 1.0, 0.0, 0.0, inf, true, 16},
                              {2.5, 1.3, 1.0, 1.5, inf, false, 8},    {3000.0, 0.05, 20.0, 5.0, inf, true, 16}};
  constexpr int kDraws = 200000;
  std::mt19937_64 rng(7);
  for (const SensorCase& c : cases) {
    const SensorModel s = c.Model();
    const LevelDistribution law(c.signal_e, s);
    ASSERT_TRUE(law.Ok()) << c.signal_e;
    std::map<int, int> model, table;
    PoissonSampler poisson;
    NormalSampler normal;
    for (int i = 0; i < kDraws; ++i) ++model[ModelPixel(c.signal_e, s, &poisson, &normal, &rng)];
    for (int i = 0; i < kDraws; ++i) ++table[law.Draw(&rng)];
    double total = 0.0;
    for (int i = 0; i < law.Size(); ++i) {
      const int dn = law.FirstDn() + i;
      const double p = law.Probability(i);
      total += p;
      const double tol = 5.0 * std::sqrt(p * (1 - p) / kDraws) + 2e-5;
      EXPECT_NEAR(model[dn] / double(kDraws), p, tol) << "signal " << c.signal_e << " DN " << dn;
      EXPECT_NEAR(table[dn] / double(kDraws), p, tol) << "signal " << c.signal_e << " DN " << dn;
      double closed = -1.0;
      if (!c.shot && c.full_well == inf) {
        const double mu = c.offset + c.gain * c.signal_e, sd = c.gain * c.read_e;
        const auto cdf = [&](double x) { return 0.5 * std::erfc(-(x - mu) / (sd * std::sqrt(2.0))); };
        closed = cdf(dn + 0.5) - (dn == 0 ? 0.0 : cdf(dn - 0.5));
      } else if (c.shot && c.read_e == 0.0 && c.gain == 1.0 && c.offset == 0.0) {
        closed = std::exp(-c.signal_e + dn * std::log(c.signal_e) - std::lgamma(dn + 1.0));
      }
      if (closed >= 0.0) {
        EXPECT_NEAR(p, closed, 1e-12) << "DN " << dn;
      }
    }
    EXPECT_NEAR(total, 1.0, 1e-12);
    EXPECT_EQ(law.Probability(-1), 0.0);
    EXPECT_EQ(law.Probability(law.Size()), 0.0);
    // Every DN drawn pixel by pixel lies in the table's support.
    EXPECT_GE(model.begin()->first, law.FirstDn());
    EXPECT_LT(model.rbegin()->first, law.FirstDn() + law.Size());
  }
  // Spread over more DN than a table holds: the caller draws pixel by pixel.
  SensorModel wide;
  wide.bit_depth = 16;
  wide.gain_dn_per_e = 5.0;  // 5000 +- 12 sqrt(5000) e- span ~8500 DN
  EXPECT_FALSE(LevelDistribution(5000.0, wide).Ok());
}

// A frame with spots draws its background from the table and the rest pixel by pixel: a flat
// background around a bright square keeps the background's law, and the square its own.
TEST(Sensor, BackgroundAndBrightRegionsKeepTheirLaws) {
  SensorModel s;
  s.read_noise_e = 2.0;
  cv::Mat signal(400, 400, CV_64FC1, cv::Scalar(8.0));
  signal(cv::Rect(100, 100, 200, 200)).setTo(cv::Scalar(120.0));
  std::mt19937_64 rng(3);
  const cv::Mat image = ApplySensor(signal, s, &rng);
  cv::Mat mask = cv::Mat::ones(400, 400, CV_8UC1);
  mask(cv::Rect(100, 100, 200, 200)).setTo(cv::Scalar(0));
  const cv::Mat inner = image(cv::Rect(100, 100, 200, 200)).clone();
  cv::Scalar mean, sd;
  cv::meanStdDev(image, mean, sd, mask);
  const double n_bg = 400.0 * 400.0 - 200.0 * 200.0, n_sq = 200.0 * 200.0;
  ExpectMoments({mean[0], sd[0] * sd[0]}, 8.0, 8.0 + 4.0 + 1.0 / 12.0, n_bg, "background");
  ExpectMoments(ImageMoments(inner), 120.0, 120.0 + 4.0 + 1.0 / 12.0, n_sq, "square");
}

TEST(Sensor, PoissonSamplerHasThePoissonLaw) {
  // Mean and variance at means on both sides of the inversion/PTRS switch, and the
  // frequencies of individual counts against the probability mass function for both methods.
  std::mt19937_64 rng(99);
  constexpr int kDraws = 200000;
  for (double mean : {0.3, 4.0, 9.99, 10.0, 37.0, 2500.0}) {
    double sum = 0.0, sum2 = 0.0;
    for (int i = 0; i < kDraws; ++i) {
      const double k = static_cast<double>(Poisson(mean, &rng));
      sum += k;
      sum2 += k * k;
    }
    const double m = sum / kDraws, var = (sum2 - kDraws * m * m) / (kDraws - 1);
    EXPECT_NEAR(m, mean, 5.0 * std::sqrt(mean / kDraws)) << mean;
    // Var of the sample variance of a Poisson: (mu4 - var^2 (n-3)/(n-1)) / n, mu4 = l(1 + 3l).
    EXPECT_NEAR(var, mean, 5.0 * std::sqrt((mean * (1 + 3 * mean) - mean * mean) / kDraws)) << mean;
  }
  for (double mean : {6.0, 20.0}) {
    std::vector<int> counts(80, 0);
    for (int i = 0; i < kDraws; ++i) {
      const std::uint64_t k = Poisson(mean, &rng);
      if (k < counts.size()) ++counts[k];
    }
    for (int k = 0; k <= 35; ++k) {
      const double p = std::exp(-mean + k * std::log(mean) - std::lgamma(k + 1.0));
      EXPECT_NEAR(counts[static_cast<std::size_t>(k)] / static_cast<double>(kDraws), p,
                  5.0 * std::sqrt(p * (1 - p) / kDraws) + 1e-5)
          << "mean " << mean << " k = " << k;
    }
  }
  EXPECT_EQ(Poisson(0.0, &rng), 0u);
  EXPECT_EQ(Poisson(-3.0, &rng), 0u);
}

TEST(Sensor, NormalSamplerHasUnitMomentsGaussianTailsAndIndependentPairs) {
  std::mt19937_64 rng(5);
  NormalSampler normal;
  constexpr int kDraws = 200000;
  double sum = 0.0, sum2 = 0.0, pair_product = 0.0;
  int beyond_2 = 0;
  for (int i = 0; i < kDraws; i += 2) {
    const double a = normal.Draw(&rng), b = normal.Draw(&rng);  // the two halves of a pair
    for (double x : {a, b}) {
      sum += x;
      sum2 += x * x;
      beyond_2 += std::abs(x) > 2.0 ? 1 : 0;
    }
    pair_product += a * b;
  }
  EXPECT_NEAR(sum / kDraws, 0.0, 5.0 / std::sqrt(kDraws));
  EXPECT_NEAR(sum2 / kDraws, 1.0, 5.0 * std::sqrt(2.0 / kDraws));
  const double p = 0.0455002638963584;  // P(|x| > 2)
  EXPECT_NEAR(beyond_2 / static_cast<double>(kDraws), p, 5.0 * std::sqrt(p * (1 - p) / kDraws));
  EXPECT_NEAR(pair_product / (kDraws / 2), 0.0, 5.0 / std::sqrt(kDraws / 2));  // uncorrelated
}

TEST(Sensor, SaturatesAtFullScaleAndFullWell) {
  std::mt19937_64 rng(3);
  SensorModel s;
  s.read_noise_e = 2.0;
  const cv::Mat bright(32, 32, CV_64FC1, cv::Scalar(5000.0));
  double lo = 0.0, hi = 0.0;
  cv::minMaxLoc(ApplySensor(bright, s, &rng), &lo, &hi);
  EXPECT_EQ(lo, 255.0);
  EXPECT_EQ(hi, 255.0);
  s.bit_depth = 16;
  s.full_well_e = 1000.0;
  s.read_noise_e = 0.0;
  cv::minMaxLoc(ApplySensor(bright, s, &rng), &lo, &hi);
  EXPECT_EQ(lo, 1000.0);
  EXPECT_EQ(hi, 1000.0);
  // Negative signals and large negative read noise clip at 0, never wrap.
  s = SensorModel::Noiseless(8, 1.0, -20.0);
  cv::minMaxLoc(ApplySensor(cv::Mat(4, 4, CV_64FC1, cv::Scalar(-5.0)), s, nullptr), &lo, &hi);
  EXPECT_EQ(hi, 0.0);
}

TEST(Sensor, NoiselessIsRoundedSignal) {
  cv::Mat signal(2, 3, CV_64FC1);
  signal.at<double>(0, 0) = 0.49;
  signal.at<double>(0, 1) = 10.51;
  signal.at<double>(0, 2) = 100.0;
  signal.at<double>(1, 0) = 254.4;
  signal.at<double>(1, 1) = 300.0;
  signal.at<double>(1, 2) = 7.25;
  const cv::Mat image = ApplySensor(signal, SensorModel::Noiseless(8, 1.0, 0.0), nullptr);
  const int expected[2][3] = {{0, 11, 100}, {254, 255, 7}};
  for (int v = 0; v < 2; ++v)
    for (int u = 0; u < 3; ++u) EXPECT_EQ(image.at<unsigned char>(v, u), expected[v][u]);
}

TEST(Sensor, RejectsBadModelsAndSignals) {
  const cv::Mat signal(4, 4, CV_64FC1, cv::Scalar(1.0));
  std::mt19937_64 rng(1);
  SensorModel s;
  s.bit_depth = 12;
  EXPECT_THROW(ApplySensor(signal, s, &rng), std::invalid_argument);
  s = SensorModel();
  s.gain_dn_per_e = 0.0;
  EXPECT_THROW(ApplySensor(signal, s, &rng), std::invalid_argument);
  s = SensorModel();
  s.read_noise_e = -1.0;
  EXPECT_THROW(ApplySensor(signal, s, &rng), std::invalid_argument);
  s = SensorModel();
  EXPECT_THROW(ApplySensor(signal, s, nullptr), std::invalid_argument);  // noisy, no engine
  EXPECT_THROW(ApplySensor(cv::Mat(4, 4, CV_32FC1), SensorModel::Noiseless(), nullptr), std::invalid_argument);
}

// Same seed, same bytes; another seed, other noise: for an LED frame and a target image.
TEST(Sensor, SameSeedSameBytesOtherSeedOtherNoise) {
  const Rig rig = PaperRig();
  CameraIntrinsics cam = rig.cameras[0].intrinsics;
  cam.width = 320;  // a corner of the paper camera keeps the test quick
  cam.height = 256;
  SensorModel sensor;
  sensor.read_noise_e = 2.5;
  LedFrameSpec spec;
  spec.beacons.push_back({0, Eigen::Vector3d(-0.4, -0.3, 1.0), {}});
  auto led = [&](std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    return RenderLedFrame(cam, spec, sensor, &rng).image;
  };
  const TargetRenderer renderer(cam);
  const CalibrationTarget board = CalibrationTarget::Checkerboard({});
  const CameraPose pose = LookAt({-0.3, 0.1, 0.5}, {0.0, 0.1, 0.0});
  auto target = [&](std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    return renderer.Render(board, pose, TargetPhotometry(), sensor, &rng);
  };
  for (const auto& render : {std::function<cv::Mat(std::uint64_t)>(led), std::function<cv::Mat(std::uint64_t)>(target)}) {
    const cv::Mat a = render(11), b = render(11), c = render(12);
    ASSERT_EQ(a.size(), b.size());
    EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
    // Read noise of 2.5 DN: nearly every pixel differs somewhere between two seeds.
    cv::Mat diff;
    cv::absdiff(a, c, diff);
    EXPECT_GT(cv::countNonZero(diff), static_cast<int>(a.total() / 2));
    // ...but only by noise: the mean picture is the same.
    EXPECT_NEAR(cv::mean(a)[0], cv::mean(c)[0], 0.1);
  }
}

}  // namespace
}  // namespace mfns::host
