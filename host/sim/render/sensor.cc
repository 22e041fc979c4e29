#include "host/sim/render/sensor.h"

#include <math.h>  // lgamma_r (POSIX)

#include <algorithm>
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

template <typename T>
void Quantise(const cv::Mat& signal_e, const SensorModel& s, std::mt19937_64* rng, cv::Mat* out) {
  const double full_scale = s.FullScale();
  PoissonSampler poisson;
  NormalSampler normal;
  for (int v = 0; v < signal_e.rows; ++v) {
    const double* in = signal_e.ptr<double>(v);
    T* row = out->ptr<T>(v);
    for (int u = 0; u < signal_e.cols; ++u) {
      const double dn = std::clamp(std::nearbyint(PixelDn(in[u], s, rng, &poisson, &normal)), 0.0, full_scale);
      row[u] = static_cast<T>(dn);
    }
  }
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

}  // namespace mfns::host
