// The tracker's motion model (issue 13 item 5): the recent accepted poses, a constant-velocity
// estimate from them, the prediction at a later time and how far the truth may lie from it.
//
// Inputs: accepted body poses (C_w_b, r_w_wb; world frame w, body frame b) with their capture
// times (monotonic ns) and 1-sigma errors (m, rad). Outputs: the predicted pose, its error
// bounds (PoseBounds: m, rad), a pose carried back along the velocity. Velocity: v_w (m/s, in
// w) and omega_b (rad/s, in b: the attitude moves as C_w_b(t + dt) = C_w_b(t) Exp(omega_b dt)).
// Memory: fixed (limits::kMaxTrackHistory poses); nothing allocates.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>

#include "common/limits.h"
#include "common/rig/rig.h"
#include "firmware/modules/identify/pose_filter.h"

namespace mfns::fw {

// Seconds from earlier_ns to later_ns (negative when later_ns is earlier).
inline double Seconds(std::uint64_t later_ns, std::uint64_t earlier_ns) {
  return later_ns >= earlier_ns ? static_cast<double>(later_ns - earlier_ns) * 1e-9
                                : -static_cast<double>(earlier_ns - later_ns) * 1e-9;
}

// The bounds of the body's motion (TrackOptions holds them; the tracker passes them on).
struct MotionLimits {
  double max_speed_m_s = 0.5;             // bound a held pose (no velocity yet)
  double max_rate_rad_s = 1.0;
  double max_accel_m_s2 = 0.1;            // bound a constant-velocity prediction: 0.5 a t^2
  double max_angular_accel_rad_s2 = 0.2;
  double slack_m = 0.02;                  // what the model leaves out (innovation slack)
  double slack_rad = 0.02;
  double sigmas = 3.0;                    // the last pose's 1-sigma counted this many times
  double velocity_window_s = 0.2;         // velocity from the poses of this last span
};

// How far a pose may lie from another: position (m) and attitude (rad, rotation angle).
struct PoseBounds {
  double max_m = 0.0;
  double max_rad = 0.0;
};

// The filter's noise for these bounds: white accelerations of spectral density max_accel^2 x 1 s
// (an acceleration at the bound sustained for about a second is a 1-sigma event), the initial
// velocity's 1-sigma the speed bounds.
PoseFilterNoise PoseFilterNoiseOf(const MotionLimits& lim);

class MotionModel {
 public:
  // No pose, no velocity, no history (the track is lost or was never found).
  void Forget();
  // A known pose at t_ns with its 1-sigma errors (m, rad; 0: exact) starts the model again: no
  // velocity; it enters the history only when exact (an uncertain pose's error over one frame
  // period would read as a fast motion).
  void Start(const BodyPose& pose, std::uint64_t t_ns, double sigma_m, double sigma_rad);
  // An accepted pose at t_ns, its 1-sigma (m, rad) for the centroid noise, and map_ratio
  // (NoiseModel::MapToCentroidRatio: its 1-sigma for the map's error over that). The velocity is
  // taken from the oldest pose of the history within lim.velocity_window_s, else the newest;
  // a history this pose does not continue (after Forget) is dropped first.
  // cov (optional): the pose's 6x6 covariance for the centroid noise (PoseDelta order), which
  // the Kalman filter (filter()) takes, grown by the map's share; without it, sigma_m / sigma_rad
  // on the diagonal.
  void Add(const BodyPose& pose, std::uint64_t t_ns, double sigma_m, double sigma_rad, double map_ratio,
           const MotionLimits& lim, const Matrix6d* cov = nullptr);

  // The constant-velocity Kalman filter over the same poses (pose_filter.h; process noise from
  // the acceleration bounds, PoseFilterNoiseOf): the prediction with a covariance, for weighing
  // trial poses against each other. Started by Start and by an Add after Forget.
  const PoseFilter& filter() const { return filter_; }

  bool known() const { return known_; }                // a last pose exists (may seed a search)
  bool has_velocity() const { return has_velocity_; }  // else the prediction holds the last pose
  const BodyPose& last_pose() const { return last_pose_; }
  std::uint64_t last_t_ns() const { return last_t_ns_; }
  // The last pose's 1-sigma for the map's error (m, rad): a bias shared by the frame sets that
  // see the same beacons.
  double last_map_sigma_m() const { return last_map_sigma_m_; }
  double last_map_sigma_rad() const { return last_map_sigma_rad_; }
  // The last pose's 6x6 covariance for the centroid noise (PoseDelta order; Add's cov, else
  // its 1-sigmas on the diagonal).
  const Matrix6d& last_cov() const { return last_cov_; }
  // How much the last pose's error grows by since_s: the velocity's lever (1 + since_s over
  // its baseline), 1 without a velocity (Bounds counts the 1-sigma this many times).
  double Lead(double since_s) const { return has_velocity_ ? 1.0 + since_s / velocity_baseline_s_ : 1.0; }

  // The pose at t_ns: constant velocity from the last pose, or the last pose held.
  BodyPose Predict(std::uint64_t t_ns) const;
  // How far the truth may lie from Predict(last + since_s): the acceleration bounds over the
  // elapsed time (with a velocity; the speed bounds for a held pose) and, for a velocity taken
  // across a gap (its baseline beyond lim.velocity_window_s: a mean over the gap), the
  // accelerations over half its baseline times since_s; lim.sigmas of the last
  // pose's 1-sigma, grown by the velocity's lever (its baseline is that much shorter than the
  // extrapolation), and the slack for what the model leaves out.
  PoseBounds Bounds(double since_s, const MotionLimits& lim) const;
  // `pose`, at t_ns, carried back by dt_s along the velocity (unchanged without one), and the
  // velocity's own error (*dv_m_s, *dv_rad_s): what the accelerations may have changed since the
  // last pose plus its 1-sigma over the velocity's baseline (the speed bounds without one).
  BodyPose CarryBack(const BodyPose& pose, std::uint64_t t_ns, double dt_s, const MotionLimits& lim,
                     double* dv_m_s, double* dv_rad_s) const;

 private:
  bool known_ = false;
  bool has_velocity_ = false;
  BodyPose last_pose_;
  std::uint64_t last_t_ns_ = 0;
  double last_sigma_m_ = 0.0, last_sigma_rad_ = 0.0;          // centroid noise
  double last_map_sigma_m_ = 0.0, last_map_sigma_rad_ = 0.0;  // map error
  Matrix6d last_cov_ = Matrix6d::Zero();                      // centroid noise
  double velocity_baseline_s_ = 1.0;                          // span the velocity was taken over
  Eigen::Vector3d v_w_ = Eigen::Vector3d::Zero();      // m/s, world
  Eigen::Vector3d omega_b_ = Eigen::Vector3d::Zero();  // rad/s, body
  void AddToFilter(const BodyPose& pose, std::uint64_t t_ns, double sigma_m, double sigma_rad, double map_ratio,
                   const MotionLimits& lim, const Matrix6d* cov);

  PoseFilter filter_;
  bool filter_pending_ = false;  // Start's pose starts the filter at the next Add
  int hist_n_ = 0;                                     // recent accepted poses, newest first
  std::array<BodyPose, limits::kMaxTrackHistory> hist_{};
  std::array<std::uint64_t, limits::kMaxTrackHistory> hist_t_ns_{};
};

}  // namespace mfns::fw
