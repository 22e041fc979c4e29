// Frame-to-frame beacon identification and pose: tracking with re-identification (issue 4
// items 5 and 6: status fix / degraded / lost with a reason).
//
// Per frame set (blobs of every camera, capture time t_ns):
// 1. Tracking, when a recent pose is known: predict the pose at t_ns (constant velocity on
//    position and attitude from the accepted poses of the last velocity_window_s; hold when
//    only one is known),
//    project every beacon, match each to the nearest blob within the gate (one-to-one; a
//    beacon with two blobs in its gate is left out), solve jointly, re-match at the solved
//    pose with a tight gate and solve again if the identities changed. The solution is
//    accepted when it has >= 3 beacons, no missing beacon (predicted well inside an image,
//    no blob), a small residual, lies where the motion model allows (innovation test: with
//    three beacons a wrong match still fits exactly, but jumps) and, with exactly three
//    observations, has no other exact solution (P3P root) consistent with the blobs nearby. The gate grows with the time since the last accepted pose
//    and with its uncertainty.
// 2. Otherwise re-identification by lost-in-space (lost_in_space.h). A fix is accepted.
//    When lost-in-space lists several consistent poses and the list is complete, they are
//    followed over the next frame sets through motion bounds (max speed and turn rate times
//    the elapsed time): a followed pose moves on to the consistent poses within its bounds,
//    or is dropped. The true pose survives every frame set with three true beacons in view;
//    a wrong one dies as soon as the motion brings a beacon into view where it predicts none. When one pose is left, confirmed by the current
//    frame set, it is accepted (source kAcquired). The pose predicted from the last accepted one
//    (if at most max_seed_s old) seeds the intersection, within acceleration bounds, so that
//    after a gap in the beacons the first frame set usually settles it.
// 3. An accepted pose is reported as fix, or degraded (fewer than fix_min_beacons beacons,
//    residual above degraded_rms_px, or 1-sigma position / attitude above their bounds);
//    otherwise the frame is lost with a reason. A tracked pose refuted by a missing beacon or
//    a large residual is forgotten; one that only lacks beacons (0-2 in view) is kept for
//    max_coast_s so tracking resumes when beacons return.
//
// Memory: one object (about 400 kB, mostly lost-in-space) holds every buffer; construct it at
// start (static or reserved), Reset() it with the rig, then Track() never allocates.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>

#include "common/limits.h"
#include "common/rig/rig.h"
#include "firmware/modules/identify/lost_in_space.h"
#include "firmware/modules/identify/match.h"
#include "firmware/modules/solve/observation.h"
#include "firmware/modules/solve/solve.h"

namespace mfns::fw {

enum class TrackStatus : unsigned char { kFix = 0, kDegraded, kLost };
inline constexpr int kNumTrackStatus = 3;
const char* ToString(TrackStatus s);

enum class TrackReason : unsigned char {
  kNone = 0,
  // kDegraded:
  kFewBeacons,       // fewer than fix_min_beacons beacons
  kLargeResidual,    // residual RMS above degraded_rms_px
  kLargeCovariance,  // 1-sigma position or attitude above its bound
  // kLost:
  kTooFewBlobs,      // fewer than 3 blobs and nothing to track
  kTooFewBeacons,    // tracking matched fewer than 3 beacons and re-identification failed
  kAcquiring,        // several poses explain the blobs; following them over frames
  kAmbiguous,        // several poses explain the blobs and the list is incomplete
  kBudgetExhausted,  // lost-in-space ran out of hypotheses
  kNoHypothesis,     // no pose explains the blobs
  kBadInput,         // invalid options, rig not set, bad blob list
};
inline constexpr int kNumTrackReason = 11;
const char* ToString(TrackReason r);

enum class TrackSource : unsigned char {
  kNone = 0,     // no pose this frame
  kTracked,      // predicted from the last poses, matched, solved
  kLostInSpace,  // a lost-in-space fix
  kAcquired,     // the one pose left of a lost-in-space ambiguity followed over frames
};
const char* ToString(TrackSource s);

struct TrackOptions {
  LisOptions lis;
  double gate_px = 10.0;             // tracking gate with a velocity prediction
  double hold_gate_px = 60.0;        // tracking gate when only one pose is known
  double gate_growth_px_per_s = 60.0;  // added per second since the last accepted pose
  double max_gate_px = 120.0;
  double gate_sigmas = 3.0;          // plus this many 1-sigma errors of the last pose, in px:
  double gate_depth_m = 0.5;         // (position errors seen at this beacon range)
  double velocity_window_s = 0.2;    // velocity from the poses of this last span
  double refine_gate_px = 4.0;       // re-matching at the solved pose
  double miss_margin_px = 15.0;      // "well inside the image" for missing beacons
  int max_missing = 0;               // more: the tracked pose is refuted
  double max_rms_px = 2.0;           // more: the tracked pose is refuted
  double max_coast_s = 2.0;          // tracking goes on this long without an accepted frame
  double max_seed_s = 5.0;           // and the last pose seeds re-acquisition this long
  // Degraded when:
  int fix_min_beacons = 3;
  double degraded_rms_px = 1.0;
  double max_position_sigma_m = 0.05;
  double max_attitude_sigma_rad = 0.02;
  // Acquisition: motion bounds between frame sets.
  double max_speed_m_s = 0.5;
  double max_rate_rad_s = 1.0;
  double max_accel_m_s2 = 0.5;       // bounds the error of a constant-velocity prediction
  double max_angular_accel_rad_s2 = 0.5;
  double chain_slack_m = 0.02;       // plus estimation noise
  double chain_slack_rad = 0.02;
  int min_acquire_frames = 3;        // frame sets an unseeded acquisition must last (>= 2)
  double chain_stale_s = 1.0;        // a followed pose unconfirmed this long restarts it all
  // A three-beacon pose is refused when another exact solution (another P3P root) consistent
  // with the blobs lies this near: the prediction cannot tell them apart.
  double twin_m = 0.2;
  double twin_rad = 0.2;
  // A tracked pose is refused when it lies farther from the prediction than this, plus the
  // acceleration bounds over the elapsed time and gate_sigmas of the last pose's 1-sigma.
  double innovation_m = 0.02;
  double innovation_rad = 0.02;
  SolveOptions solve;

  bool IsValid(const char** why = nullptr) const;
};

struct TrackResult {
  TrackStatus status = TrackStatus::kLost;
  TrackReason reason = TrackReason::kBadInput;
  TrackSource source = TrackSource::kNone;
  std::uint64_t t_ns = 0;
  BodyPose pose;                 // valid unless kLost
  MatchSet matches;              // identities used by the solve (inliers), unless kLost
  SolveResult solve;             // covariance, residuals, beacons per camera, unless kLost
  bool lis_run = false;          // lost-in-space ran this frame
  LisStatus lis_status = LisStatus::kBadInput;
  int acquisition_poses = 0;     // poses still followed (kAcquiring)
};

// A counter per outcome, for health reporting.
struct TrackCounters {
  std::uint32_t frames = 0;
  std::array<std::uint32_t, kNumTrackStatus> by_status{};
  std::array<std::uint32_t, kNumTrackReason> by_reason{};
  std::uint32_t tracked = 0, lost_in_space_fixes = 0, acquired = 0;
  std::uint32_t lis_runs = 0, track_refuted = 0, innovation_refused = 0;
  SolveCounters solve;
};

class Tracker {
 public:
  // Forgets every pose. The rig must stay alive and unchanged until the next Reset.
  bool Reset(const Rig& rig);

  // Starts tracking from a known pose at t_ns (e.g. the flyer leaves its dock): no velocity
  // yet, so the next frame set is matched with hold_gate_px.
  void SetPose(const BodyPose& pose, std::uint64_t t_ns);

  // Identifies and solves one frame set; t_ns is its capture time (monotonic, ns).
  TrackStatus Track(const BlobObs* blobs, int num_blobs, std::uint64_t t_ns, const TrackOptions& options,
                    TrackResult* result);

  const TrackCounters& counters() const { return counters_; }

 private:
  BodyPose Predict(std::uint64_t t_ns) const;
  bool TrackFrom(const BodyPose& predicted, double since_s, double gate_px, const TrackOptions& o, TrackResult* r,
                 bool* refuted);
  bool SolveAt(const BodyPose& start, const TrackOptions& o, TrackResult* r);
  bool NearbyTwin(const TrackOptions& o, const TrackResult* r);
  void PrepareChain(std::uint64_t t_ns, const TrackOptions& o);
  bool ChainPrior(std::uint64_t t_ns, const TrackOptions& o, LisPrior* prior);
  bool Acquire(std::uint64_t t_ns, const TrackOptions& o, TrackResult* r);
  void Accept(std::uint64_t t_ns, const TrackOptions& o, TrackResult* r);
  TrackStatus Lost(TrackReason why, TrackResult* r);

  const Rig* rig_ = nullptr;
  const BlobObs* blobs_ = nullptr;
  int num_blobs_ = 0;
  BeaconMatcher matcher_;
  LostInSpace lis_;
  LisResult lis_res_;
  MatchSet set_;
  P3pRayTriple twin_;
  std::array<BodyPose, limits::kMaxP3pSolutions> twin_poses_{};
  MatchSet twin_set_;
  // The last accepted pose and the motion estimate.
  bool has_pose_ = false;  // tracking may predict from last_pose_
  bool has_seed_ = false;  // last_pose_ may seed re-acquisition
  BodyPose last_pose_;
  std::uint64_t last_t_ns_ = 0;
  bool has_velocity_ = false;
  double velocity_baseline_s_ = 1.0;
  double last_sigma_rad_ = 0.0;  // attitude 1-sigma of the last pose
  double last_sigma_m_ = 0.0;    // position 1-sigma of the last pose
  double px_per_rad_ = 0.0;      // largest focal length of the rig
  int hist_n_ = 0;               // recent accepted poses, newest first
  std::array<BodyPose, limits::kMaxTrackHistory> hist_{};
  std::array<std::uint64_t, limits::kMaxTrackHistory> hist_t_ns_{};
  Eigen::Vector3d v_w_ = Eigen::Vector3d::Zero();      // m/s, world
  Eigen::Vector3d omega_b_ = Eigen::Vector3d::Zero();  // rad/s, body
  // Acquisition: the poses not refuted by any frame set since the chain started, each with
  // the time it was last confirmed (found consistent by lost-in-space) and its motion bounds.
  int chain_n_ = 0;
  int chain_frames_ = 0;
  bool chain_seeded_ = false;
  double prior_max_m_ = 0.0, prior_max_rad_ = 0.0;
  std::array<BodyPose, limits::kMaxLisCandidates> chain_{};
  std::array<std::uint64_t, limits::kMaxLisCandidates> chain_t_{};
  std::array<double, limits::kMaxLisCandidates> chain_max_m_{};
  std::array<double, limits::kMaxLisCandidates> chain_max_rad_{};
  std::array<BodyPose, limits::kMaxLisCandidates> chain_next_{};
  std::array<std::uint64_t, limits::kMaxLisCandidates> chain_next_t_{};
  TrackCounters counters_;
};

}  // namespace mfns::fw
