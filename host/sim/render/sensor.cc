#include "host/sim/render/sensor.h"

#include <math.h>  // lgamma_r (POSIX)

#include <algorithm>
#include <array>
#include <utility>
#include <vector>
#include <cmath>
#include <stdexcept>
#include <string>

namespace mfns::host {
namespace {

constexpr double kTwoPi = 6.283185307179586476925;

// Bound of the sequential search: P(k >= 100) < 1e-60 below mean 10, and it stops a search
// that rounding keeps just short of a uniform draw near 1.
constexpr int kMaxInversionCount = 100;

// Means above this (far beyond any full well) are returned as the cap, keeping every count
// representable; Inf lands here too.
constexpr double kMaxPoissonMean = 1e15;

// One pixel through the model of sensor.h, before rounding.
double PixelDn(double signal_e, const SensorModel& s, std::mt19937_64* rng, PoissonSampler* poisson,
               NormalSampler* normal) {
  double e = std::clamp(std::max(0.0, signal_e), 0.0, kMaxPoissonMean);  // NaN or < 0: no light
  if (s.shot_noise) e = static_cast<double>(poisson->Draw(e, rng));
  e = std::min(e, s.full_well_e);
  if (s.read_noise_e > 0.0) e += s.read_noise_e * normal->Draw(rng);
  return s.offset_dn + s.gain_dn_per_e * e;
}

// The most common signal among 8x8 pixels spread over the frame: its background level.
double CommonLevel(const cv::Mat& signal_e) {
  std::array<double, 64> samples{};
  std::size_t n = 0;
  for (int j = 0; j < 8; ++j)
    for (int i = 0; i < 8; ++i) samples[n++] = signal_e.at<double>(j * (signal_e.rows - 1) / 7, i * (signal_e.cols - 1) / 7);
  std::sort(samples.begin(), samples.end());
  double best = samples[0];
  std::size_t best_run = 0;
  for (std::size_t i = 0, run = 1; i < samples.size(); ++i, ++run) {
    if (i + 1 < samples.size() && samples[i + 1] == samples[i]) continue;
    if (run > best_run) best = samples[i], best_run = run;
    run = 0;
  }
  return best;
}

template <typename T>
void Quantise(const cv::Mat& signal_e, const SensorModel& s, std::mt19937_64* rng, cv::Mat* out) {
  const double full_scale = s.FullScale();
  PoissonSampler poisson;
  NormalSampler normal;
  // A noiseless model draws nothing (rng may be null): every pixel takes the direct path.
  const bool noisy = s.shot_noise || s.read_noise_e > 0.0;
  const double level = CommonLevel(signal_e);
  const LevelDistribution background(noisy ? level : 0.0, s);
  const bool tabulated = noisy && background.Ok();
  for (int v = 0; v < signal_e.rows; ++v) {
    const double* in = signal_e.ptr<double>(v);
    T* row = out->ptr<T>(v);
    for (int u = 0; u < signal_e.cols; ++u) {
      if (tabulated && in[u] == level) {
        row[u] = static_cast<T>(background.Draw(rng));
        continue;
      }
      const double dn = std::clamp(std::nearbyint(PixelDn(in[u], s, rng, &poisson, &normal)), 0.0, full_scale);
      row[u] = static_cast<T>(dn);
    }
  }
}

// Probability of the Poisson count k for the given mean (k! through lgamma: any k).
double PoissonPmf(double k, double mean) {
  if (!(mean > 0.0)) return k == 0.0 ? 1.0 : 0.0;
  int sign = 0;
  return std::exp(k * std::log(mean) - mean - ::lgamma_r(k + 1.0, &sign));
}

// P(clamp(nearbyint(x), 0, full_scale) = d) for x ~ N(mu, sd^2), sd > 0. Ties of nearbyint
// have probability 0.
double RoundedNormalProbability(int d, double mu, double sd, int full_scale) {
  const auto cdf = [&](double x) { return 0.5 * std::erfc(-(x - mu) / (sd * std::sqrt(2.0))); };
  const double upper = d >= full_scale ? 1.0 : cdf(d + 0.5);
  const double lower = d <= 0 ? 0.0 : cdf(d - 0.5);
  return std::max(0.0, upper - lower);
}

}  // namespace

SensorModel SensorModel::Noiseless(int bit_depth, double gain_dn_per_e, double offset_dn) {
  SensorModel s;
  s.bit_depth = bit_depth;
  s.gain_dn_per_e = gain_dn_per_e;
  s.offset_dn = offset_dn;
  s.shot_noise = false;
  s.read_noise_e = 0.0;
  return s;
}

void ValidateSensor(const SensorModel& s) {
  if (s.bit_depth != 8 && s.bit_depth != 16)
    throw std::invalid_argument("sensor: bit_depth must be 8 or 16, not " + std::to_string(s.bit_depth));
  if (!(s.gain_dn_per_e > 0.0) || !std::isfinite(s.gain_dn_per_e))
    throw std::invalid_argument("sensor: gain_dn_per_e must be > 0");
  if (!std::isfinite(s.offset_dn)) throw std::invalid_argument("sensor: offset_dn must be finite");
  if (!(s.read_noise_e >= 0.0) || !std::isfinite(s.read_noise_e))
    throw std::invalid_argument("sensor: read_noise_e must be >= 0");
  if (!(s.full_well_e > 0.0)) throw std::invalid_argument("sensor: full_well_e must be > 0");
}

cv::Mat ApplySensor(const cv::Mat& signal_e, const SensorModel& sensor, std::mt19937_64* rng) {
  ValidateSensor(sensor);
  if (signal_e.empty() || signal_e.type() != CV_64FC1)
    throw std::invalid_argument("sensor: signal must be a non-empty CV_64FC1 image");
  if (rng == nullptr && (sensor.shot_noise || sensor.read_noise_e > 0.0))
    throw std::invalid_argument("sensor: a noisy model needs a random engine");
  cv::Mat out(signal_e.size(), sensor.bit_depth == 8 ? CV_8UC1 : CV_16UC1);
  if (sensor.bit_depth == 8) {
    Quantise<unsigned char>(signal_e, sensor, rng, &out);
  } else {
    Quantise<std::uint16_t>(signal_e, sensor, rng, &out);
  }
  return out;
}

double Uniform01(std::mt19937_64* rng) {
  return static_cast<double>((*rng)() >> 11) * 0x1.0p-53;
}

double NormalSampler::Draw(std::mt19937_64* rng) {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  const double u1 = 1.0 - Uniform01(rng);  // (0, 1]: log(u1) is finite
  const double u2 = Uniform01(rng);
  const double r = std::sqrt(-2.0 * std::log(u1));
  spare_ = r * std::sin(kTwoPi * u2);
  has_spare_ = true;
  return r * std::cos(kTwoPi * u2);
}

void PoissonSampler::Prepare(double mean) {
  mean_ = mean;
  if (mean < 10.0) {
    exp_neg_mean_ = std::exp(-mean);
    return;
  }
  // PTRS constants, W. Hoermann, "The transformed rejection method for generating Poisson
  // random variables", Insurance: Mathematics and Economics 12 (1993) 39-45.
  log_mean_ = std::log(mean);
  b_ = 0.931 + 2.53 * std::sqrt(mean);
  a_ = -0.059 + 0.02483 * b_;
  log_inv_alpha_ = std::log(1.1239 + 1.1328 / (b_ - 3.4));
  v_r_ = 0.9277 - 3.6224 / (b_ - 2.0);
}

std::uint64_t PoissonSampler::Draw(double mean, std::mt19937_64* rng) {
  if (!(mean > 0.0)) return 0;
  if (!(mean <= kMaxPoissonMean)) return static_cast<std::uint64_t>(kMaxPoissonMean);
  if (mean != mean_) Prepare(mean);  // uniform regions reuse the constants
  if (mean < 10.0) {
    // Inversion: the smallest k whose cumulative probability exceeds one uniform draw.
    const double u = Uniform01(rng);
    double p = exp_neg_mean_, cumulative = p;
    int k = 0;
    while (u >= cumulative && k < kMaxInversionCount) {
      ++k;
      p *= mean / k;
      cumulative += p;
    }
    return static_cast<std::uint64_t>(k);
  }
  for (;;) {
    const double u = Uniform01(rng) - 0.5;
    const double v = Uniform01(rng);
    const double us = 0.5 - std::abs(u);
    const double k = std::floor((2.0 * a_ / us + b_) * u + mean + 0.43);
    if (us >= 0.07 && v <= v_r_) return static_cast<std::uint64_t>(k);
    if (k < 0.0 || (us < 0.013 && v > us)) continue;
    int sign = 0;  // lgamma_r: std::lgamma writes the global signgam (a data race across threads)
    if (std::log(v) + log_inv_alpha_ - std::log(a_ / (us * us) + b_) <=
        -mean + k * log_mean_ - ::lgamma_r(k + 1.0, &sign))
      return static_cast<std::uint64_t>(k);
  }
}

std::uint64_t Poisson(double mean, std::mt19937_64* rng) { return PoissonSampler().Draw(mean, rng); }

LevelDistribution::LevelDistribution(double signal_e, const SensorModel& s) {
  const double mean = std::clamp(std::max(0.0, signal_e), 0.0, kMaxPoissonMean);  // as PixelDn
  if (mean > kMaxMean) return;
  // Electron counts after the full well, with their probabilities (12 sigma + 10 of Poisson
  // reach: the tails left out weigh < 1e-30).
  std::vector<std::pair<double, double>> counts;
  if (s.shot_noise) {
    const double reach = 12.0 * std::sqrt(mean) + 10.0;
    for (double k = std::max(0.0, std::floor(mean - reach)); k <= std::ceil(mean + reach); ++k)
      counts.emplace_back(std::min(k, s.full_well_e), PoissonPmf(k, mean));
  } else {
    counts.emplace_back(std::min(mean, s.full_well_e), 1.0);
  }
  const int full_scale = s.FullScale();
  const double sd_dn = s.gain_dn_per_e * s.read_noise_e;
  const auto dn_of = [&](double e) { return s.offset_dn + s.gain_dn_per_e * e; };
  const auto clamp_dn = [&](double x) { return static_cast<int>(std::clamp(std::nearbyint(x), 0.0, double(full_scale))); };
  const int lo = clamp_dn(dn_of(counts.front().first) - 12.0 * sd_dn - 1.0);
  const int hi = clamp_dn(dn_of(counts.back().first) + 12.0 * sd_dn + 1.0);
  if (hi - lo + 1 > kMaxValues) return;
  std::vector<double> pmf(static_cast<std::size_t>(hi - lo + 1), 0.0);
  for (const auto& [e, p] : counts) {
    if (!(p > 0.0)) continue;
    if (!(sd_dn > 0.0)) {
      pmf[static_cast<std::size_t>(clamp_dn(dn_of(e)) - lo)] += p;
      continue;
    }
    const int d0 = std::max(lo, clamp_dn(dn_of(e) - 12.0 * sd_dn - 1.0));
    const int d1 = std::min(hi, clamp_dn(dn_of(e) + 12.0 * sd_dn + 1.0));
    for (int d = d0; d <= d1; ++d) pmf[static_cast<std::size_t>(d - lo)] += p * RoundedNormalProbability(d, dn_of(e), sd_dn, full_scale);
  }
  double total = 0.0;
  for (const double p : pmf) total += p;
  if (!(total > 0.0)) return;
  first_dn_ = lo;
  cdf_.resize(pmf.size());
  double running = 0.0;
  for (std::size_t i = 0; i < pmf.size(); ++i) cdf_[i] = (running += pmf[i]) / total;
  cdf_.back() = 1.0;  // u < 1 always finds a value
  guide_.resize(kGuideBins);
  std::size_t i = 0;
  for (int b = 0; b < kGuideBins; ++b) {
    while (cdf_[i] <= static_cast<double>(b) / kGuideBins) ++i;
    guide_[static_cast<std::size_t>(b)] = static_cast<int>(i);
  }
}

double LevelDistribution::Probability(int i) const {
  if (i < 0 || i >= Size()) return 0.0;
  return cdf_[static_cast<std::size_t>(i)] - (i == 0 ? 0.0 : cdf_[static_cast<std::size_t>(i) - 1]);
}

int LevelDistribution::Draw(std::mt19937_64* rng) const {
  const double u = Uniform01(rng);
  std::size_t i = static_cast<std::size_t>(guide_[static_cast<std::size_t>(u * kGuideBins)]);
  while (cdf_[i] <= u) ++i;  // ends: cdf_.back() is 1 > u
  return first_dn_ + static_cast<int>(i);
}

}  // namespace mfns::host
