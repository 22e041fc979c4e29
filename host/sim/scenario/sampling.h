// Samplers on the raw output of std::mt19937_64 (whose sequence the C++ standard fixes), so a
// seed gives the same modules, beacon maps and trajectories with any standard library
// (std::uniform_real_distribution and std::normal_distribution are implementation-defined).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <random>

namespace mfns::host {

// Uniform in [0, 1) with 53 random bits.
inline double Uniform01(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

inline double UniformIn(double lo, double hi, std::mt19937_64& rng) { return lo + (hi - lo) * Uniform01(rng); }

// Standard normal by Box-Muller (one draw per pair of uniforms: no state kept between calls).
inline double StandardNormal(std::mt19937_64& rng) {
  const double u1 = 1.0 - Uniform01(rng);  // (0, 1]: log(u1) is finite
  const double u2 = Uniform01(rng);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * 3.14159265358979323846 * u2);
}

inline Eigen::Vector3d StandardNormal3(std::mt19937_64& rng) {
  const double x = StandardNormal(rng), y = StandardNormal(rng), z = StandardNormal(rng);
  return {x, y, z};
}

// A rotation uniform on SO(3) (Haar measure): a quaternion from 4 independent normals.
inline Eigen::Matrix3d UniformRotation(std::mt19937_64& rng) {
  Eigen::Vector4d q;
  do {
    for (int i = 0; i < 4; ++i) q[i] = StandardNormal(rng);
  } while (q.norm() < 1e-9);
  q.normalize();
  return Eigen::Quaterniond(q[0], q[1], q[2], q[3]).toRotationMatrix();
}

// An engine for one named purpose of a seed: independent streams for the beacon map, the
// trajectory, the error sources..., so changing one never shifts another's draws.
inline std::mt19937_64 SeededStream(std::uint64_t seed, std::uint32_t purpose, std::uint32_t a = 0,
                                    std::uint32_t b = 0) {
  std::seed_seq seq{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32), purpose, a, b};
  return std::mt19937_64(seq);
}

}  // namespace mfns::host
