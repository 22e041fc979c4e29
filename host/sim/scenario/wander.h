// A free-flyer wandering through a station module: smooth 6-DOF random motion from a seed,
// starting anywhere (scenario YAML `trajectory: {kind: wander}`).
//
// Start: position uniform in the module shrunk by `margin` on every side, attitude uniform on
// SO(3). Motion: the commanded velocity (world) and body rate are Ornstein-Uhlenbeck processes
// (correlation time `correlation_s`, 1-sigma a third of the limit per axis, clamped to the
// limits); the flyer tracks them with accelerations clamped to max_accel / max_angular_accel.
// Walls: a command heading into a wall within its stopping distance is reflected off it, and
// the velocity towards each wall is held to the speed from which max_accel / 2 stops the flyer
// before a band (`WanderBuffer`) inside the margin, so the flyer never comes closer to a wall
// than `margin` (tests: scenario_test Wander.*).
// Bounds by construction: |v| <= max_speed, |omega| <= max_rate (the frame-to-frame position
// and attitude changes divided by the frame period are exactly these), |dv/dt| <= max_accel,
// |domega/dt| <= max_angular_accel.
#pragma once

#include <cstdint>
#include <vector>

#include "common/rig/rig.h"
#include "host/sim/scenario/module.h"

namespace mfns::host {

struct WanderLimits {
  double margin = 0.3;              // m from every wall
  double max_speed = 0.3;           // m/s
  double max_accel = 0.1;           // m/s^2
  double max_rate = 0.5;            // rad/s
  double max_angular_accel = 0.5;   // rad/s^2
  double correlation_s = 5.0;       // s
};

// The band inside the margin that the steering aims to stay out of (m): the tracking lag of
// the velocity loop plus two frames of travel. The module needs room for margin + band.
double WanderBuffer(const WanderLimits& limits, double dt);

// `frames` body poses at period dt (s), deterministic for `seed`. Needs a module with room
// (every inner extent > 2 (margin + WanderBuffer)) and positive limits.
std::vector<BodyPose> WanderPoses(const StationModule& module, const WanderLimits& limits, int frames, double dt,
                                  std::uint64_t seed);

}  // namespace mfns::host
