// The tracker's acquisition (issue 13 item 5): the poses followed over frame sets while
// lost-in-space cannot tell which of several consistent poses is the truth.
//
// Each followed pose (FollowedPose) keeps the time it was last confirmed (found in a frame
// set's complete list of consistent poses) and how far it may have moved since (its motion
// bounds). Per frame set: Prepare (drop stale chains, seed from the motion model's prediction,
// set the bounds), Prior (lost-in-space only looks near them), then Follow with the frame set's
// complete list: every listed pose within the bounds of a followed one is followed on, the
// others dropped. The true pose is in every complete list when three true beacons are in view,
// so it survives; a wrong one dies when the motion brings a beacon into view where it predicts
// none. Deciding when the one pose left is accepted stays with the tracker (it needs the
// blobs, the matcher and the solve).
//
// Poses: body pose (C_w_b, r_w_wb) in the world frame; times: monotonic ns; bounds: m, rad.
// Memory: fixed (limits::kMaxLisCandidates followed poses, twice, and a copy for the prior).
#pragma once

#include <array>
#include <cstdint>

#include "common/limits.h"
#include "common/rig/rig.h"
#include "firmware/modules/identify/lost_in_space.h"
#include "firmware/modules/identify/motion_model.h"

namespace mfns::fw {

// One pose followed by the acquisition.
struct FollowedPose {
  BodyPose pose;
  std::uint64_t t_ns = 0;  // when it was last confirmed (ns)
  PoseBounds bounds;       // how far it may have moved since then (set by Prepare)
};

// The acquisition's bounds beside the motion model's (TrackOptions holds them).
struct AcquisitionLimits {
  MotionLimits motion;     // speed and rate bound an unseeded pose's motion between frame sets
  double slack_m = 0.02;   // plus estimation noise
  double slack_rad = 0.02;
  double stale_s = 1.0;    // a followed pose unconfirmed this long restarts it all
};

class Acquisition {
 public:
  void Clear() {
    n_ = 0;
    steady_ = false;
  }
  int size() const { return n_; }
  bool empty() const { return n_ == 0; }
  // Frame sets the chain has lasted (a seeded chain counts its seed as the first).
  int frames() const { return frames_; }
  // Started from the motion model's prediction rather than from lost-in-space's list.
  bool seeded() const { return seeded_; }
  // Followed from a steady list (LisResult::steady_complete) at least once: the truth is in the
  // chain only while it explains four steady blobs, so every followed pose must (the tracker
  // keeps those, Tracker::OnFourSteadyBlobs). Until Clear, a new Start or a new seed.
  bool steady() const { return steady_; }
  void MarkSteady() { steady_ = true; }
  const BodyPose& pose(int i) const { return chain_[static_cast<std::size_t>(i)].pose; }

  // Readies the followed poses for the frame set at t_ns: drops them all when one has gone
  // unconfirmed longer than stale_s; with none left and `seed` given (a recent accepted pose),
  // follows its prediction, whose error bounds (MotionModel::Bounds) then hold the truth; sets
  // each pose's motion bounds since its last confirmation (the seed's prediction bounds in the
  // frame set it seeds, else the speed bounds) plus the slack.
  void Prepare(std::uint64_t t_ns, const AcquisitionLimits& lim, const MotionModel* seed);
  // Lost-in-space's prior: the followed poses and the largest of their bounds (false: none).
  // prior points into this object until the next call that changes it.
  bool Prior(LisPrior* prior);
  // Starts the chain from a frame set's (complete, or steady: LisResult::steady_complete) list
  // of consistent poses, unseeded.
  void Start(const LisResult& list, std::uint64_t t_ns);
  // Follows the chain with a frame set's complete (or steady) list; empty afterwards when no
  // listed pose lies within the bounds of a followed one.
  void Follow(const LisResult& list, std::uint64_t t_ns);
  // Keeps the followed poses for which keep(pose) is true (order kept); returns how many
  // were dropped.
  template <typename Keep>
  int Retain(Keep keep) {
    int n = 0;
    for (int i = 0; i < n_; ++i)
      if (keep(chain_[static_cast<std::size_t>(i)].pose)) chain_[static_cast<std::size_t>(n++)] = chain_[static_cast<std::size_t>(i)];
    const int dropped = n_ - n;
    n_ = n;
    return dropped;
  }

 private:
  int n_ = 0;
  int frames_ = 0;
  bool seeded_ = false;
  bool steady_ = false;
  PoseBounds largest_;  // the largest bounds of the followed poses (Prepare)
  std::array<FollowedPose, limits::kMaxLisCandidates> chain_{};
  std::array<FollowedPose, limits::kMaxLisCandidates> next_{};
  std::array<BodyPose, limits::kMaxLisCandidates> prior_poses_{};  // LisPrior wants poses alone
};

}  // namespace mfns::fw
