// A constant-velocity Kalman filter over the track's accepted poses (issue 13): where the body
// will be at a later capture time, and how uncertain that prediction is, as a 6x6 covariance
// that a trial pose can be weighed against (squared Mahalanobis distance).
//
// State: pose (r_w_wb, C_w_b), velocity v_w (m/s, world) and body rate omega_b (rad/s, body:
// C_w_b(t + dt) = C_w_b(t) Exp(omega_b dt)). Error state (12): [dr_w (m); dtheta_b (rad, body,
// C_true = C Exp(dtheta_b)); dv_w; domega_b], the first six the solve's PoseDelta
// (common/rig/rig.h), so a solve's covariance is the measurement covariance as it is.
// Process noise: white acceleration, spectral densities accel_psd (m^2/s^3) and
// angular_accel_psd (rad^2/s^3) per axis: over dt the velocity's variance grows by psd dt, the
// position's by psd dt^3 / 3 (the classic continuous white-noise-acceleration model).
// Memory: fixed-size Eigen types; nothing allocates.
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "common/rig/rig.h"

namespace mfns::fw {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

struct PoseFilterNoise {
  double accel_psd = 0.01;             // m^2/s^3: a 0.1 m/s^2 acceleration sustained ~1 s
  double angular_accel_psd = 0.04;     // rad^2/s^3
  double initial_speed_sigma = 0.5;    // m/s: the velocity's 1-sigma when the filter starts
  double initial_rate_sigma = 1.0;     // rad/s

  bool IsValid() const;
};

class PoseFilter {
 public:
  using Matrix12d = Eigen::Matrix<double, 12, 12>;
  using Vector12d = Eigen::Matrix<double, 12, 1>;

  // No state (the track is lost).
  void Forget() { started_ = false; }
  // Starts at `pose` (t_ns, its 6x6 covariance in PoseDelta order), velocity zero with the
  // noise's initial sigmas. False (nothing started) for invalid noise, a non-finite pose or a
  // covariance that is not finite.
  bool Start(const BodyPose& pose, std::uint64_t t_ns, const Matrix6d& pose_cov, const PoseFilterNoise& noise);
  // Propagates to t_ns and fuses the measured pose z (covariance R, PoseDelta order). False
  // (state unchanged) when not started, t_ns is earlier than the state's time, or the
  // innovation covariance is not positive definite.
  bool Update(const BodyPose& z, std::uint64_t t_ns, const Matrix6d& R);

  // The pose at t_ns (>= the state's time; an earlier time predicts the state's own) and the
  // pose block of its covariance. False when not started.
  bool Predict(std::uint64_t t_ns, BodyPose* pose, Matrix6d* P_pose) const;
  // Squared Mahalanobis distance of a measured pose z (covariance R) from the prediction at
  // t_ns: d^T (P_pose + R)^-1 d, d = [z.r - r; Log(C^T z.C)]; chi-square with 6 degrees of
  // freedom when the filter is consistent. Infinity when not started or singular.
  double Distance2(const BodyPose& z, const Matrix6d& R, std::uint64_t t_ns) const;

  bool started() const { return started_; }
  std::uint64_t t_ns() const { return t_ns_; }
  const BodyPose& pose() const { return pose_; }
  const Eigen::Vector3d& v_w() const { return v_w_; }
  const Eigen::Vector3d& omega_b() const { return omega_b_; }
  const Matrix12d& covariance() const { return P_; }

  // The error-state transition and process noise over dt at body rate omega_b (exposed for
  // the finite-difference test).
  static Matrix12d Transition(const Eigen::Vector3d& omega_b, double dt);
  static Matrix12d ProcessNoise(const PoseFilterNoise& noise, double dt);

 private:
  void Propagate(std::uint64_t t_ns, BodyPose* pose, Matrix12d* P) const;

  bool started_ = false;
  PoseFilterNoise noise_;
  std::uint64_t t_ns_ = 0;
  BodyPose pose_;
  Eigen::Vector3d v_w_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d omega_b_ = Eigen::Vector3d::Zero();
  Matrix12d P_ = Matrix12d::Zero();
};

}  // namespace mfns::fw
