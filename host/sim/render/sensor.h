// Sensor model of the simulator: expected photo-electrons per pixel -> digital numbers (DN).
//
// For each pixel, in row-major order, with the expected signal s (electrons; negative or NaN
// counts as 0, above 1e15 as 1e15):
//   e  = Poisson(s)            photon shot noise         (s itself when shot_noise is false)
//   e  = min(e, full_well_e)   pixel saturation          (optional)
//   e += N(0, read_noise_e^2)  read noise                (none when read_noise_e is 0)
//   DN = clamp(round(offset_dn + gain_dn_per_e * e), 0, 2^bit_depth - 1)
// so a flat field of s electrons has mean offset + g s and variance g^2 (s + read^2) + 1/12
// (the last term from rounding) while unclipped.
//
// Pixels whose signal equals the frame's most common level (its background: nearly all pixels
// of a beacon frame) are drawn from that level's output distribution, tabulated once per frame
// (LevelDistribution): one uniform per pixel instead of a Poisson and a normal draw. The law
// of every pixel is the same (up to tail probabilities below 1e-15); the bytes differ from a
// pixel-by-pixel draw of the same seed.
//
// Randomness: every draw comes from the caller's std::mt19937_64 through the samplers below,
// which use only the engine's raw 64-bit output (whose sequence the C++ standard fixes), not
// std::normal_distribution / std::poisson_distribution (whose algorithms differ between
// standard libraries). So the same seed gives the same bytes with any compiler.
#pragma once

#include <cstdint>
#include <limits>
#include <opencv2/core.hpp>
#include <random>
#include <vector>

namespace mfns::host {

struct SensorModel {
  int bit_depth = 8;             // 8 -> CV_8UC1 output, 16 -> CV_16UC1
  double gain_dn_per_e = 1.0;    // conversion gain, DN per electron (> 0)
  double offset_dn = 0.0;        // black level added to every pixel, DN
  bool shot_noise = true;        // Poisson photon noise on the electrons
  double read_noise_e = 0.0;     // 1-sigma Gaussian read noise, electrons (>= 0)
  double full_well_e = std::numeric_limits<double>::infinity();  // electrons (> 0)

  // A sensor that adds no randomness at all (for zero-noise ground truth).
  static SensorModel Noiseless(int bit_depth = 8, double gain_dn_per_e = 1.0, double offset_dn = 0.0);
  // Full-scale DN: 255 or 65535.
  int FullScale() const { return (1 << bit_depth) - 1; }
};

// Throws std::invalid_argument on a bit depth other than 8/16, gain <= 0, negative read noise,
// full_well_e <= 0 or non-finite fields (except an infinite full well).
void ValidateSensor(const SensorModel& sensor);

// Converts a CV_64FC1 signal (electrons; negative values count as 0) into a CV_8UC1 or
// CV_16UC1 frame. Draws from *rng only when the model is noisy. Throws std::invalid_argument
// on a bad model or signal type.
cv::Mat ApplySensor(const cv::Mat& signal_e, const SensorModel& sensor, std::mt19937_64* rng);

// Samplers on the raw engine output (see above). Uniform01 is in [0, 1) with 53 random bits.
double Uniform01(std::mt19937_64* rng);

// Standard normal draws by the Box-Muller transform; each pair of uniforms gives two draws,
// the second kept for the next call. Deterministic for a given engine state.
class NormalSampler {
 public:
  double Draw(std::mt19937_64* rng);

 private:
  double spare_ = 0.0;
  bool has_spare_ = false;
};

// Poisson(mean) draws: inversion by sequential search below mean 10 (one uniform per draw),
// Hoermann's PTRS transformed rejection (1993) above. mean <= 0 or NaN gives 0; means above
// 1e15 (and Inf) give 1e15. The sampler keeps the constants of the last mean (a flat region
// costs one exp or log, not one per pixel); the draws do not depend on that cache.
class PoissonSampler {
 public:
  std::uint64_t Draw(double mean, std::mt19937_64* rng);

 private:
  void Prepare(double mean);
  double mean_ = -1.0;
  double exp_neg_mean_ = 0.0;                                       // inversion
  double log_mean_ = 0.0, a_ = 0.0, b_ = 0.0, log_inv_alpha_ = 0.0, v_r_ = 0.0;  // PTRS
};

// One draw with a fresh sampler.
std::uint64_t Poisson(double mean, std::mt19937_64* rng);

// The law of one pixel's DN for one expected signal (electrons), as the model above defines
// it, tabulated for inverse-CDF draws: P(DN = d) sums, over the Poisson counts k within 12
// sigma of the mean, Poisson(k) times the probability that the read noise rounds
// offset + gain min(k, full well) to d (clamped at 0 and full scale). Ok() is false when the
// law spreads over more than kMaxValues DN or the mean is beyond kMaxMean (the caller then
// draws pixel by pixel). Draw takes one uniform (53 bits) from the engine.
class LevelDistribution {
 public:
  static constexpr int kMaxValues = 4096;
  static constexpr double kMaxMean = 1e6;

  LevelDistribution(double signal_e, const SensorModel& sensor);
  bool Ok() const { return !cdf_.empty(); }
  int FirstDn() const { return first_dn_; }
  // P(DN = FirstDn() + i), i < Size().
  double Probability(int i) const;
  int Size() const { return static_cast<int>(cdf_.size()); }
  // One DN of this law.
  int Draw(std::mt19937_64* rng) const;

 private:
  static constexpr int kGuideBins = 256;
  int first_dn_ = 0;
  std::vector<double> cdf_;  // cdf_[i] = P(DN <= first_dn_ + i); the last is exactly 1
  std::vector<int> guide_;   // guide_[b]: the first i with cdf_[i] > b / kGuideBins
};

}  // namespace mfns::host
