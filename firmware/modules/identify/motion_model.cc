#include "firmware/modules/identify/motion_model.h"

#include <cmath>

#include "common/rotation/rotation.h"

namespace mfns::fw {

PoseFilterNoise PoseFilterNoiseOf(const MotionLimits& lim) {
  PoseFilterNoise n;
  n.accel_psd = lim.max_accel_m_s2 * lim.max_accel_m_s2 * 1.0;
  n.angular_accel_psd = lim.max_angular_accel_rad_s2 * lim.max_angular_accel_rad_s2 * 1.0;
  n.initial_speed_sigma = lim.max_speed_m_s;
  n.initial_rate_sigma = lim.max_rate_rad_s;
  return n;
}

namespace {
Matrix6d DiagonalCov(double sigma_m, double sigma_rad) {
  Matrix6d P = Matrix6d::Zero();
  P.diagonal() << Eigen::Vector3d::Constant(sigma_m * sigma_m), Eigen::Vector3d::Constant(sigma_rad * sigma_rad);
  return P;
}
}  // namespace

void MotionModel::Forget() {
  filter_.Forget();
  filter_pending_ = false;
  known_ = has_velocity_ = false;
  hist_n_ = 0;
}

void MotionModel::Start(const BodyPose& pose, std::uint64_t t_ns, double sigma_m, double sigma_rad) {
  known_ = true;
  has_velocity_ = false;
  last_pose_ = pose;
  last_t_ns_ = t_ns;
  last_sigma_m_ = std::isfinite(sigma_m) ? std::max(0.0, sigma_m) : 0.0;
  last_sigma_rad_ = std::isfinite(sigma_rad) ? std::max(0.0, sigma_rad) : 0.0;
  last_map_sigma_m_ = last_map_sigma_rad_ = 0.0;
  last_cov_ = DiagonalCov(last_sigma_m_, last_sigma_rad_);
  hist_n_ = last_sigma_m_ == 0.0 && last_sigma_rad_ == 0.0 ? 1 : 0;
  hist_[0] = pose;
  hist_t_ns_[0] = t_ns;
  // The filter starts from this pose at the next Add, which brings the motion bounds.
  filter_.Forget();
  filter_pending_ = true;
}

void MotionModel::Add(const BodyPose& pose, std::uint64_t t_ns, double sigma_m, double sigma_rad, double map_ratio,
                      const MotionLimits& lim, const Matrix6d* cov) {
  if (!known_) {
    hist_n_ = 0;
    filter_.Forget();
    filter_pending_ = false;
  }
  AddToFilter(pose, t_ns, sigma_m, sigma_rad, map_ratio, lim, cov);
  // The oldest pose within the window: a longer baseline averages the noise of single poses;
  // across a gap bridged by the prediction, the newest is all there is.
  int from = -1;
  for (int i = 0; i < hist_n_; ++i) {
    const double age = Seconds(t_ns, hist_t_ns_[static_cast<std::size_t>(i)]);
    if (age > 0.0 && (from < 0 || age <= lim.velocity_window_s)) from = i;
  }
  has_velocity_ = false;
  if (from >= 0) {
    const double age = Seconds(t_ns, hist_t_ns_[static_cast<std::size_t>(from)]);
    const BodyPose& old = hist_[static_cast<std::size_t>(from)];
    v_w_ = (pose.r_w_wb - old.r_w_wb) / age;
    omega_b_ = LogSO3(old.C_w_b.transpose() * pose.C_w_b) / age;
    velocity_baseline_s_ = age;
    has_velocity_ = true;
  }
  // History: newest first, bounded.
  hist_n_ = std::min(hist_n_ + 1, limits::kMaxTrackHistory);
  for (int i = hist_n_ - 1; i > 0; --i) {
    hist_[static_cast<std::size_t>(i)] = hist_[static_cast<std::size_t>(i - 1)];
    hist_t_ns_[static_cast<std::size_t>(i)] = hist_t_ns_[static_cast<std::size_t>(i - 1)];
  }
  hist_[0] = pose;
  hist_t_ns_[0] = t_ns;
  known_ = true;
  last_pose_ = pose;
  last_t_ns_ = t_ns;
  last_sigma_m_ = sigma_m;
  last_sigma_rad_ = sigma_rad;
  last_cov_ = cov != nullptr ? *cov : DiagonalCov(sigma_m, sigma_rad);
  last_map_sigma_m_ = map_ratio * last_sigma_m_;
  last_map_sigma_rad_ = map_ratio * last_sigma_rad_;
}

void MotionModel::AddToFilter(const BodyPose& pose, std::uint64_t t_ns, double sigma_m, double sigma_rad,
                              double map_ratio, const MotionLimits& lim, const Matrix6d* cov) {
  const PoseFilterNoise noise = PoseFilterNoiseOf(lim);
  if (filter_pending_) {
    filter_.Start(last_pose_, last_t_ns_, last_cov_, noise);  // Start's pose and 1-sigmas
    filter_pending_ = false;
  }
  Matrix6d R = cov != nullptr ? *cov : DiagonalCov(sigma_m, sigma_rad);
  R *= 1.0 + map_ratio * map_ratio;
  if (!filter_.Update(pose, t_ns, R)) filter_.Start(pose, t_ns, R, noise);
}

BodyPose MotionModel::Predict(std::uint64_t t_ns) const {
  if (!has_velocity_) return last_pose_;
  const double dt = Seconds(t_ns, last_t_ns_);
  BodyPose p;
  p.r_w_wb = last_pose_.r_w_wb + v_w_ * dt;
  p.C_w_b = last_pose_.C_w_b * ExpSO3(omega_b_ * dt);
  return p;
}

PoseBounds MotionModel::Bounds(double since_s, const MotionLimits& lim) const {
  const double lead = Lead(since_s);
  PoseBounds b;
  b.max_m = lim.slack_m + lim.sigmas * last_sigma_m_ * lead;
  b.max_rad = lim.slack_rad + lim.sigmas * last_sigma_rad_ * lead;
  if (has_velocity_) {
    // The accelerations since the last pose, and, for a velocity taken across a gap (a baseline
    // beyond the window), its own error: a mean over the baseline, it may differ from the
    // velocity at the last pose by half the baseline's accelerations (a velocity across a 2.5 s
    // gap predicted beacons 20 px off one frame set later, the track was refuted and 17 frame
    // sets of cold search followed). Within the window the slack and the 1-sigma cover it.
    const double lag_s = velocity_baseline_s_ > lim.velocity_window_s ? 0.5 * velocity_baseline_s_ * since_s : 0.0;
    b.max_m += lim.max_accel_m_s2 * (0.5 * since_s * since_s + lag_s);
    b.max_rad += lim.max_angular_accel_rad_s2 * (0.5 * since_s * since_s + lag_s);
  } else {
    b.max_m += lim.max_speed_m_s * since_s;
    b.max_rad += lim.max_rate_rad_s * since_s;
  }
  return b;
}

BodyPose MotionModel::CarryBack(const BodyPose& pose, std::uint64_t t_ns, double dt_s, const MotionLimits& lim,
                                double* dv_m_s, double* dv_rad_s) const {
  BodyPose back = pose;
  *dv_m_s = lim.max_speed_m_s;
  *dv_rad_s = lim.max_rate_rad_s;
  if (has_velocity_) {
    back.r_w_wb = pose.r_w_wb - v_w_ * dt_s;
    back.C_w_b = pose.C_w_b * ExpSO3(-omega_b_ * dt_s);
    const double since = std::max(0.0, Seconds(t_ns, last_t_ns_));
    *dv_m_s = lim.max_accel_m_s2 * since + lim.sigmas * last_sigma_m_ / velocity_baseline_s_;
    *dv_rad_s = lim.max_angular_accel_rad_s2 * since + lim.sigmas * last_sigma_rad_ / velocity_baseline_s_;
  }
  return back;
}

}  // namespace mfns::fw
