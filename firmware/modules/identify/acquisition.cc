#include "firmware/modules/identify/acquisition.h"

#include <algorithm>

#include "common/rotation/rotation.h"

namespace mfns::fw {

void Acquisition::Prepare(std::uint64_t t_ns, const AcquisitionLimits& lim, const MotionModel* seed) {
  for (int i = 0; i < n_; ++i)
    if (Seconds(t_ns, chain_[static_cast<std::size_t>(i)].t_ns) > lim.stale_s) n_ = 0;
  bool seeded_now = false;
  if (n_ == 0 && seed != nullptr) {
    // The true pose is within the prediction's error bounds (MotionModel::Bounds), counted
    // from the seed's time.
    n_ = 1;
    chain_[0].pose = seed->Predict(t_ns);
    chain_[0].t_ns = seed->last_t_ns();
    frames_ = 1;
    seeded_now = seeded_ = true;
    steady_ = false;
  }
  largest_ = PoseBounds{};
  for (int i = 0; i < n_; ++i) {
    FollowedPose& f = chain_[static_cast<std::size_t>(i)];
    const double dt = std::max(0.0, Seconds(t_ns, f.t_ns));
    if (seeded_now) {
      f.bounds = seed->Bounds(dt, lim.motion);
      f.bounds.max_m += lim.slack_m;
      f.bounds.max_rad += lim.slack_rad;
    } else {
      f.bounds.max_m = lim.motion.max_speed_m_s * dt + lim.slack_m;
      f.bounds.max_rad = lim.motion.max_rate_rad_s * dt + lim.slack_rad;
    }
    largest_.max_m = std::max(largest_.max_m, f.bounds.max_m);
    largest_.max_rad = std::max(largest_.max_rad, f.bounds.max_rad);
  }
}

bool Acquisition::Prior(LisPrior* prior) {
  if (n_ == 0) return false;
  for (int i = 0; i < n_; ++i) prior_poses_[static_cast<std::size_t>(i)] = chain_[static_cast<std::size_t>(i)].pose;
  prior->poses = prior_poses_.data();
  prior->num_poses = n_;
  prior->max_m = largest_.max_m;
  prior->max_rad = largest_.max_rad;
  return true;
}

void Acquisition::Start(const LisResult& list, std::uint64_t t_ns) {
  n_ = std::min(list.num_consistent, limits::kMaxLisCandidates);
  for (int i = 0; i < n_; ++i) {
    FollowedPose& f = chain_[static_cast<std::size_t>(i)];
    f.pose = list.consistent_poses[static_cast<std::size_t>(i)];
    f.t_ns = t_ns;
  }
  frames_ = 1;
  seeded_ = false;
  steady_ = false;
}

void Acquisition::Follow(const LisResult& list, std::uint64_t t_ns) {
  // Every consistent pose within the bounds of a followed one is followed on (any of them may
  // be the truth); a followed pose with none is dropped.
  int n = 0;
  for (int i = 0; i < list.num_consistent && n < limits::kMaxLisCandidates; ++i) {
    const BodyPose& p = list.consistent_poses[static_cast<std::size_t>(i)];
    bool near = false;
    for (int j = 0; j < n_ && !near; ++j) {
      const FollowedPose& f = chain_[static_cast<std::size_t>(j)];
      near = (p.r_w_wb - f.pose.r_w_wb).norm() <= f.bounds.max_m &&
             LogSO3(f.pose.C_w_b.transpose() * p.C_w_b).norm() <= f.bounds.max_rad;
    }
    if (!near) continue;
    next_[static_cast<std::size_t>(n)] = FollowedPose{p, t_ns, PoseBounds{}};
    ++n;
  }
  n_ = n;
  if (n == 0) return;
  std::copy(next_.begin(), next_.begin() + n, chain_.begin());
  ++frames_;
}

}  // namespace mfns::fw
