#include "host/sim/scenario/wander.h"

#include <algorithm>
#include <cmath>

#include "common/rotation/rotation.h"
#include "host/sim/scenario/sampling.h"

namespace mfns::host {
namespace {

constexpr std::uint32_t kWanderStream = 0x3a4de7u;
// Velocity and rate tracking gains (1/s): the flyer follows its commands within ~0.5 s.
constexpr double kGain = 2.0;
constexpr double kMaxStep = 0.06;  // s: integration step (kGain * kMaxStep < 1)

Eigen::Vector3d ClampNorm(const Eigen::Vector3d& v, double max_norm) {
  const double n = v.norm();
  return n > max_norm ? Eigen::Vector3d(v * (max_norm / n)) : v;
}

// One Ornstein-Uhlenbeck step of a commanded vector (stationary 1-sigma limit / 3 per axis).
Eigen::Vector3d OuStep(const Eigen::Vector3d& x, double limit, double tau, double dt, std::mt19937_64& rng) {
  const double sigma = limit / 3.0;
  return ClampNorm(x - x * (dt / tau) + sigma * std::sqrt(2.0 * dt / tau) * StandardNormal3(rng), limit);
}

// The flyer's braking deceleration towards a wall: half the acceleration budget, so the
// velocity loop has the other half to track it.
double Braking(const WanderLimits& l) { return 0.5 * l.max_accel; }

// The command reflected off every wall it heads into within its stopping distance (plus the
// margin and band): the flyer turns away instead of sliding along the wall.
Eigen::Vector3d ReflectOffWalls(Eigen::Vector3d v_cmd, const StationModule& module, const Eigen::Vector3d& p,
                                double keep_out, const WanderLimits& l) {
  std::array<WallConstraint, 6> walls;
  const int n = WallConstraints(module, p, &walls);
  for (int i = 0; i < n; ++i) {
    const WallConstraint& w = walls[static_cast<std::size_t>(i)];
    const double towards = v_cmd.dot(w.n_out);
    if (towards > 0.0 && w.clearance - keep_out < towards * towards / (2.0 * Braking(l)) + 0.1)
      v_cmd -= 2.0 * towards * w.n_out;
  }
  return v_cmd;
}

// The goal velocity: the command with its speed towards each wall held to what braking stops
// at the keep-out distance (and an inward push when already inside it).
Eigen::Vector3d WallLimited(Eigen::Vector3d v, const StationModule& module, const Eigen::Vector3d& p, double keep_out,
                            const WanderLimits& l) {
  std::array<WallConstraint, 6> walls;
  const int n = WallConstraints(module, p, &walls);
  for (int i = 0; i < n; ++i) {
    const WallConstraint& w = walls[static_cast<std::size_t>(i)];
    const double d = w.clearance - keep_out;
    const double allowed = std::copysign(std::sqrt(2.0 * Braking(l) * std::abs(d)), d);
    const double towards = v.dot(w.n_out);
    if (towards > allowed) v -= (towards - allowed) * w.n_out;
  }
  return ClampNorm(v, l.max_speed);
}

}  // namespace

double WanderBuffer(const WanderLimits& l, double dt) {
  return Braking(l) / (kGain * kGain) + 2.0 * l.max_speed * std::min(dt, kMaxStep);
}

std::vector<BodyPose> WanderPoses(const StationModule& module, const WanderLimits& l, int frames, double dt,
                                  std::uint64_t seed) {
  std::mt19937_64 rng = SeededStream(seed, kWanderStream);
  const double keep_out = l.margin + WanderBuffer(l, dt);
  BodyPose pose;
  pose.r_w_wb = UniformInside(module, l.margin, &rng);
  pose.C_w_b = UniformRotation(rng);
  Eigen::Vector3d v_cmd = ClampNorm(l.max_speed / 3.0 * StandardNormal3(rng), l.max_speed);
  Eigen::Vector3d w_cmd = ClampNorm(l.max_rate / 3.0 * StandardNormal3(rng), l.max_rate);  // body frame
  // Already moving at the start (a flyer found mid-flight), within the wall limits.
  Eigen::Vector3d v = WallLimited(ReflectOffWalls(v_cmd, module, pose.r_w_wb, keep_out, l), module, pose.r_w_wb,
                                  keep_out, l);
  Eigen::Vector3d w = w_cmd;
  std::vector<BodyPose> out;
  out.reserve(static_cast<std::size_t>(std::max(frames, 0)));
  // Sub-steps of at most kMaxStep keep kGain * h < 1: each moves v towards a goal within the
  // speed limit, so |v| stays within it (likewise the rate), whatever the frame rate.
  const int substeps = std::max(1, static_cast<int>(std::ceil(dt / kMaxStep)));
  const double h = dt / substeps;
  for (int i = 0; i < frames; ++i) {
    out.push_back(pose);
    for (int j = 0; j < substeps; ++j) {
      v_cmd = ReflectOffWalls(OuStep(v_cmd, l.max_speed, l.correlation_s, h, rng), module, pose.r_w_wb, keep_out, l);
      w_cmd = OuStep(w_cmd, l.max_rate, l.correlation_s, h, rng);
      const Eigen::Vector3d v_goal = WallLimited(v_cmd, module, pose.r_w_wb, keep_out, l);
      v += ClampNorm(kGain * (v_goal - v), l.max_accel) * h;
      w += ClampNorm(kGain * (w_cmd - w), l.max_angular_accel) * h;
      pose.r_w_wb += v * h;
      pose.C_w_b = pose.C_w_b * ExpSO3(w * h);
    }
  }
  return out;
}

}  // namespace mfns::host
