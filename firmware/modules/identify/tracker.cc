#include "firmware/modules/identify/tracker.h"

#include <algorithm>
#include <bit>
#include <cmath>

#include "common/rotation/rotation.h"
#include "firmware/modules/identify/identities.h"

namespace mfns::fw {

namespace {
// A tracking trial (solve with its outlier rounds, re-matches, tests) in LisResult::cost units
// (0.62 us): a lost-in-space refinement (kCostRefine there, fitted in session 17) plus a term per
// beacon and blob (the matches' nearest-blob scans, the outlier rounds' re-solves). Measured in
// session 34 with 66 blobs per camera in a 128-beacon box: eleven leave-outs of 16 trials took
// 18.8 ms, ~0.1 ms a trial, 170 units; this gives 166 there and 22 with 10 blobs.
constexpr double kCostTrackingSolve = 14.0;
constexpr double kCostMatchPerBeaconBlob = 6e-3;

// The largest 1-sigma of a [position (m); attitude (rad)] covariance's position and attitude.
double PositionSigma(const Eigen::Matrix<double, 6, 6>& P) { return std::sqrt(std::max({P(0, 0), P(1, 1), P(2, 2)})); }
// Whether a lies within tol_m / tol_rad of b (position, rotation angle).
bool PoseWithin(const BodyPose& a, const BodyPose& b, double tol_m, double tol_rad) {
  return (a.r_w_wb - b.r_w_wb).norm() <= tol_m && LogSO3(b.C_w_b.transpose() * a.C_w_b).norm() <= tol_rad;
}
double AttitudeSigma(const Eigen::Matrix<double, 6, 6>& P) { return std::sqrt(std::max({P(3, 3), P(4, 4), P(5, 5)})); }

AcquisitionLimits LimitsOf(const TrackOptions& o) {
  AcquisitionLimits a;
  a.motion = MotionLimits{o.max_speed_m_s,  o.max_rate_rad_s, o.max_accel_m_s2, o.max_angular_accel_rad_s2,
                          o.innovation_m,   o.innovation_rad, o.gate_sigmas,    o.velocity_window_s};
  a.slack_m = o.chain_slack_m;
  a.slack_rad = o.chain_slack_rad;
  a.stale_s = o.chain_stale_s;
  return a;
}

}  // namespace

const char* ToString(TrackStatus s) {
  switch (s) {
    case TrackStatus::kFix: return "fix";
    case TrackStatus::kDegraded: return "degraded";
    case TrackStatus::kLost: return "lost";
    case TrackStatus::kCount: break;
  }
  return "unknown track status";
}

const char* ToString(TrackReason r) {
  switch (r) {
    case TrackReason::kNone: return "none";
    case TrackReason::kFewBeacons: return "few beacons";
    case TrackReason::kLargeResidual: return "large residual";
    case TrackReason::kLargeCovariance: return "large covariance";
    case TrackReason::kUnverified: return "unverified: three beacons only";
    case TrackReason::kTooFewBlobs: return "too few blobs";
    case TrackReason::kTooFewBeacons: return "too few beacons matched";
    case TrackReason::kAcquiring: return "acquiring: several poses explain the blobs";
    case TrackReason::kAmbiguous: return "ambiguous";
    case TrackReason::kBudgetExhausted: return "hypothesis budget exhausted";
    case TrackReason::kNoHypothesis: return "no pose explains the blobs";
    case TrackReason::kRepeatedView: return "the map repeats this view";
    case TrackReason::kBadInput: return "bad input";
    case TrackReason::kCount: break;
  }
  return "unknown track reason";
}

const char* ToString(TrackSource s) {
  switch (s) {
    case TrackSource::kNone: return "none";
    case TrackSource::kTracked: return "tracked";
    case TrackSource::kLostInSpace: return "lost-in-space";
    case TrackSource::kAcquired: return "acquired";
    case TrackSource::kCount: break;
  }
  return "unknown track source";
}

bool Tracker::Reset(const Rig& rig) {
  rig_ = nullptr;
  prev_num_blobs_ = -1;
  has_pose_ = false;
  last_fix_ = false;
  verified_ = given_seed_ = false;
  view_repeated_ = false;
  motion_.Forget();
  acquisition_.Clear();
  lis_owner_ = LisOwner::kNone;
  counters_ = TrackCounters{};
  blob_tracks_.Reset();
  beacon_track_.fill(0);
  if (!lis_.Reset(rig)) return false;
  matcher_.Reset(rig);
  rig_ = &rig;
  noise_ = NoiseModel::OfRig(rig);
  return true;
}

void Tracker::SetExcludedBeacons(const BeaconSet& beacons) {
  matcher_.SetExcluded(beacons);
  lis_.SetExcluded(beacons);
}

void Tracker::SetPose(const BodyPose& pose, std::uint64_t t_ns, double sigma_m, double sigma_rad, bool verified) {
  prev_num_blobs_ = -1;
  has_pose_ = true;
  last_fix_ = false;  // its 1-sigma alone: the pose-space gate
  verified_ = verified;  // given (a dock, a carried-over track) or a confirmed fix
  given_seed_ = true;
  motion_.Start(pose, t_ns, sigma_m, sigma_rad);
  acquisition_.Clear();
  lis_owner_ = LisOwner::kNone;
}

// Solve from `start` with the identities in set_, then re-match with the tight gate and solve
// again while they change (bounded). r->matches and r->solve hold the outcome.
bool Tracker::SolveAt(const BodyPose& start, const TwinRegion& twin, const TrackOptions& o, TrackResult* r) {
  BodyPose pose = start;
  // (A beacon moved since the survey, its blob beyond the tight gate, is a near miss: excused
  // once on a pose of lis.near_miss_min_beacons beacons; beacon health judges it.)
  const MatchOptions tight = WithNearMisses(MatchOptions{o.refine_gate_px, o.miss_margin_px, false}, o.lis);
  for (int round = 0; round < 3; ++round) {
    const SolveStatus s =
        SolvePose(*rig_, blobs_, num_blobs_, set_.matches.data(), set_.num_matches, pose, o.solve, &r->solve);
    counters_.solve.Record(r->solve);
    if (s != SolveStatus::kOk) return false;
    pose = r->solve.pose;
    matcher_.MatchPose(pose, tight, &r->matches);
    int shared = 0;
    const bool stable = r->matches.num_matches == set_.num_matches && Compatible(r->matches, set_, &shared) &&
                        shared == set_.num_matches;
    set_ = r->matches;
    if (stable) break;
  }
  // The identities the last solve used, inliers only.
  r->matches.Retain([&](int i, const Match&) { return r->solve.inlier[static_cast<std::size_t>(i)]; });
  r->pose = r->solve.pose;
  return r->matches.num_beacons >= 3 && UnexcusedMissing(r->matches, o.lis) <= o.max_missing &&
         r->solve.rms_px <= o.max_rms_px && !NearbyTwin(twin, o, r);
}

// Three observations fit a pose exactly, and so do up to three other poses (the P3P's other
// roots). When another root consistent with the blobs lies inside the region where the truth
// may be (the prediction's error bounds when tracking; twin_m / twin_rad around the solution
// otherwise), nothing tells the two apart and the solver may have settled on the wrong one:
// true then. A root outside that region is refuted by the motion model.
bool Tracker::NearbyTwin(const TwinRegion& region, const TrackOptions& o, const TrackResult* r) {
  if (r->matches.num_matches != 3) return false;
  std::array<BodyRay, 3> rays;
  std::array<Eigen::Vector3d, 3> P;
  for (std::size_t i = 0; i < 3; ++i) {
    const Match& m = r->matches.matches[i];
    rays[i] = RayOfBlob(*rig_, blobs_[m.blob]);
    P[i] = rig_->beacons_w[static_cast<std::size_t>(m.beacon)];
  }
  P3pOptions p3p = o.lis.p3p;
  if (p3p.max_depth_m <= 0.0) p3p.max_depth_m = 10.0;
  if (!twin_.Set(rays, p3p)) return false;
  const BodyPose& centre = region.centre != nullptr ? *region.centre : r->pose;
  const int n = twin_.Solve(P, &twin_poses_);
  for (int i = 0; i < n; ++i) {
    const BodyPose& q = twin_poses_[static_cast<std::size_t>(i)];
    const double dr = (q.r_w_wb - r->pose.r_w_wb).norm();
    const double da = LogSO3(r->pose.C_w_b.transpose() * q.C_w_b).norm();
    if (dr < 1e-3 && da < 1e-3) continue;  // the solution itself (the noise moves it a little)
    if ((q.r_w_wb - centre.r_w_wb).norm() > region.max_m ||
        LogSO3(centre.C_w_b.transpose() * q.C_w_b).norm() > region.max_rad)
      continue;
    matcher_.MatchPose(q, MatchOptions{o.refine_gate_px, o.miss_margin_px, false}, &twin_set_);
    if (twin_set_.num_missing <= o.max_missing) return true;
  }
  return false;
}

// Tracking from the motion model's prediction at t_ns (since_s after its last pose). While the
// gate that covers the prediction's error bounds stays within max_gate_px, a beacon predicted
// well inside an image with no blob in its gate refutes the prediction (then forgotten);
// otherwise, while the track holds (has_pose_), the blobs are matched and solved (TrackFrom).
// True when r holds this frame set's outcome; false: re-identify.
bool Tracker::TrackPredicted(std::uint64_t t_ns, double since_s, const TrackOptions& o, TrackResult* r) {
  const BodyPose predicted = motion_.Predict(t_ns);
  const PoseBounds bounds = motion_.Bounds(since_s, limits_.motion);
  double gate = 0.0, gate_with_map = 0.0;
  PredictionGatePx(predicted, since_s, o, &gate, &gate_with_map);
  bool refuted = false;
  if (gate > o.max_gate_px && has_pose_ && since_s <= o.velocity_window_s &&
      TrackContinuing(predicted, bounds, o, r)) {
    Publish(TrackSource::kTracked, t_ns, o, r);
    return true;
  }
  if (gate <= o.max_gate_px) {
    gate = std::min(o.max_gate_px, gate_with_map);
    // A beacon predicted well inside an image (by more than the gate) with no blob in its
    // gate refutes the prediction (a kidnapped body, a wrong track).
    matcher_.MatchPose(predicted, MatchOptions{gate, o.miss_margin_px + gate, false}, &set_);
    refuted = set_.num_missing > o.max_missing;
    if (!refuted && has_pose_) {
      if (TrackFrom(predicted, bounds, gate, o, r, &refuted)) {
        // Residuals beyond the noise: one bad beacon (moved, or a reflection taken for it) may
        // bend the pose; leaving it out gives a better one (degraded all the same).
        if (o.leave_one_out && !ResidualsFitTheNoise(r->solve, o)) LeaveOneOut(predicted, bounds, gate, o, r);
        Publish(TrackSource::kTracked, t_ns, o, r);
        return true;
      }
      if (!ambiguity_refused_ && o.leave_one_out && LeaveOneOut(predicted, bounds, gate, o, r)) {
        Publish(TrackSource::kTracked, t_ns, o, r);
        return true;
      }
      if (ambiguity_refused_ && PublishAmbiguous(o, r)) return true;
      if (ambiguity_refused_ && DecideByMotion(predicted, bounds, o, r)) {
        // Published, not followed: were the choice wrong, tracking from it could later turn it
        // into a fix (seen on aarch64, paper sweep with two spurious blobs: a fix 16 mm / 1.2 deg
        // off on a reflection). The track coasts on from the last accepted pose.
        ++counters_.ambiguous_decided;
        ++counters_.tracked;
        acquisition_.Clear();
        PublishUnfollowed(r);
        return true;
      }
    }
  }
  if (refuted) {
    ++counters_.track_refuted;
    has_pose_ = false;  // the prior disagrees with the blobs: forget it
    motion_.Forget();
    acquisition_.Clear();
  }
  return false;
}

// Tracking from the prediction. Beacons with one blob in the gate are matched to it; one with
// two (a reflection beside it) is tried with either (max_ambiguous_tried of them: 2^n trials).
// A trial with a wrong blob is refuted by its residual or, with three beacons, by the
// innovation test, or lands near the true pose when the solve's outlier rejection and the
// tight re-match put the right blob back. The best consistent trial (most beacons, then
// lowest residual) is the tracked pose when every consistent trial agrees with it; otherwise
// nothing is tracked (never a guess). *refuted: every trial was refuted by the blobs.
bool Tracker::TrackFrom(const BodyPose& predicted, const PoseBounds& bounds, double gate_px, const TrackOptions& o,
                        TrackResult* r, bool* refuted) {
  *refuted = false;
  matcher_.MatchPose(predicted, MatchOptions{gate_px, o.miss_margin_px, true}, &base_, &ambiguous_);
  ContinueTracks(o);
  const int n = std::min(ambiguous_.num, o.max_ambiguous_tried);
  if (n > 0) ++counters_.ambiguous_tried;
  int tried = 0, refutations = 0, consistent = 0, competitors = 0;
  bool best_steady = false;
  for (std::uint32_t choice = 0; choice < (1U << n); ++choice) {
    if (!ChooseAmbiguous(choice, n) || set_.num_beacons < 3) continue;
    ++tried;
    bool trial_refuted = false;
    double innovation = -1.0;
    const bool ok = SolveTracked(predicted, bounds, o, &trial_, &trial_refuted, &innovation);
    refutations += trial_refuted;
    // A trial the innovation test refused by a small factor still competes (the truth itself
    // may lie just beyond the motion bounds: then the one inside them is not the truth).
    if (!ok && !(n > 0 && innovation > 0.0 && innovation <= o.ambiguity_innovation_factor)) continue;
    trials_[static_cast<std::size_t>(competitors++)] =
        Trial{trial_.pose, trial_.matches.num_beacons, trial_.solve.cost, choice,
              trial_.solve.has_covariance ? trial_.solve.covariance : Matrix6d::Zero()};
    if (!ok) continue;
    // Among trials that explain as many beacons about as well (three beacons fit exactly), one on
    // steady blobs beats one resting on a blob that continues no image track (a reflection
    // flickering beside its beacon); then the smaller residual.
    const int nb = trial_.matches.num_beacons;
    const bool steady = OnSteadyBlobs(trial_.matches);
    const bool alike = std::abs(trial_.solve.cost - r->solve.cost) * 2.0 <= o.ambiguity_chi2 * noise_.ResidualVariancePx2();
    bool better = false;
    if (consistent == 0 || nb > r->matches.num_beacons) better = true;
    else if (nb < r->matches.num_beacons) better = false;
    else if (alike && steady != best_steady) better = steady;  // as many beacons, about as well
    else better = trial_.solve.rms_px < r->solve.rms_px;
    ++consistent;
    if (better) {
      best_steady = steady;
      r->pose = trial_.pose;
      r->matches = trial_.matches;
      r->solve = trial_.solve;
    }
  }
  *refuted = tried > 0 && refutations == tried;
  num_trials_ = competitors;
  if (consistent == 0) return false;
  if (!AgreeWith(*r, competitors, o)) {
    ++counters_.ambiguous_refused;
    ambiguity_refused_ = true;
    return false;
  }
  return true;
}

// Tracking when the gate is too wide for nearest-blob matching (TrackOptions::
// continuity_max_m2): the blobs that continue the steady image tracks of beacons of the accepted
// poses (ContinuingBlobs) are those beacons, solved from `predicted` with tracking's tests
// (SolveTracked: tight re-match, nothing missing, no twin within the bounds, the innovation).
// Three beacons fit any pose exactly, and the bounds after a three-beacon pose are centimetres
// and degrees wide, so the pose must also lie where the motion filter expects it: a blob track
// that jumped to a reflection beside its beacon (within the blob tracker's tight gate) bends a
// three-beacon pose by far more than its 1-sigma.
bool Tracker::TrackContinuing(const BodyPose& predicted, const PoseBounds& bounds, const TrackOptions& o,
                              TrackResult* r) {
  const PoseFilter& f = motion_.filter();
  // (Not an unverified track: its identities may be an unmapped light's alias, which carrying
  // them on would keep alive; re-identification looks at the frame set afresh.)
  if (!(o.continuity_max_m2 > 0.0) || !f.started() || (o.verify_three_beacons && !verified_) || ContinuingBlobs(o) < 3)
    return false;
  set_ = MatchSet{};
  for (int i = 0; i < num_continuing_; ++i) {
    const ContinuingBlob& c = continuing_[static_cast<std::size_t>(i)];
    set_.Add(Match{c.blob, c.beacon, blobs_[c.blob].camera});
  }
  if (set_.num_beacons < 3) return false;
  bool refuted = false;
  double innovation = -1.0;
  const double k2 = noise_.TotalToCentroid() * noise_.TotalToCentroid();
  // (Beyond a fix's 1-sigma bounds the motion filter's test means little.)
  if (!SolveTracked(predicted, bounds, o, r, &refuted, &innovation) || BeyondFixSigmas(r->solve, o) ||
      !(f.Distance2(r->pose, k2 * r->solve.covariance, now_ns_) <= o.continuity_max_m2)) {
    ++counters_.continuity_refused;
    return false;
  }
  ++counters_.continued;
  return true;
}

// The pose on every beacon near `predicted` was refused (tracking's trials, or a lost-in-space
// fix's residuals). Each of those beacons is left out in turn (of matching: never missing) and
// the blobs are tracked again from `predicted` (TrackFrom: its trials of ambiguous beacons, the
// innovation test); a leave-out fits when that gives a pose on >= 4 beacons whose residuals
// fit the noise. Exactly one must fit: its pose is in *r, with left_out_beacon. With >= 5
// beacons a wrong leave-out keeps the bad beacon among four, whose residuals refuse it.
// When no single leave-out fits and the pose stood on leave_two_out_min_beacons or more (up to
// leave_two_out_max_beacons), each pair of them is left out instead: two beacons moved together
// (a panel with two of its LEDs) leave one bad beacon in every single leave-out. Published with
// both (TrackResult::left_out_second).
bool Tracker::LeaveOneOut(const BodyPose& predicted, const PoseBounds& bounds, double gate_px, const TrackOptions& o,
                          TrackResult* r) {
  matcher_.MatchPose(predicted, MatchOptions{gate_px, o.miss_margin_px, false}, &loo_set_);
  const int n = loo_set_.num_beacons, nb = rig_->num_beacons;
  if (n < o.leave_one_out_min_beacons || n > o.leave_one_out_max_beacons) return false;
  const BeaconSet excluded = matcher_.excluded(), candidates = loo_set_.beacons;
  const bool refused = ambiguity_refused_;
  const TrackCounters counters = counters_;  // the trials below are not tracking's own
  int fits = 0, out_a = -1, out_b = -1;
  bool budget_out = false;
  const auto leave_out = [&](int a, int b) {  // exactly one must fit: stop at the second
    // Each leave-out is a tracking with its trials, charged like lost-in-space's work: with many
    // blobs beside the beacons (2^4 trials each) they took 20 ms of a frame set.
    if (lis_budget_left_ <= 0.0) {
      budget_out = true;
      return;
    }
    const bool fit = LeaveOutFits(predicted, bounds, gate_px, o, excluded, a, b);
    Charge((kCostTrackingSolve + kCostMatchPerBeaconBlob * nb * num_blobs_) *
           (1 << std::min(ambiguous_.num, o.max_ambiguous_tried)));
    if (!fit || ++fits > 1) return;
    out_a = a;
    out_b = b;
    loo_best_ = loo_result_;
  };
  for (int a = 0; a < nb && fits < 2 && !budget_out; ++a)
    if (candidates.Has(a)) leave_out(a, -1);
  const bool pairs = fits == 0 && o.leave_two_out_min_beacons > 0 && n >= o.leave_two_out_min_beacons &&
                     n <= o.leave_two_out_max_beacons;
  for (int a = 0; pairs && a < nb && fits < 2 && !budget_out; ++a)
    for (int b = a + 1; candidates.Has(a) && b < nb && fits < 2 && !budget_out; ++b)
      if (candidates.Has(b)) leave_out(a, b);
  matcher_.SetExcluded(excluded);
  ambiguity_refused_ = refused;
  counters_ = counters;
  if (budget_out) {  // (one fit so far may have a second among the leave-outs not tried)
    ++counters_.left_out_budget_out;
    return false;
  }
  if (fits != 1) {
    ++counters_.left_out_undecided;
    return false;
  }
  ++counters_.left_out;
  if (out_b >= 0) ++counters_.left_two_out;
  r->pose = loo_best_.pose;
  r->matches = loo_best_.matches;
  r->solve = loo_best_.solve;
  r->left_out_beacon = out_a;
  r->left_out_second = out_b;
  return true;
}

// One leave-out of LeaveOneOut: beacon a (and b, unless -1) also left out of matching, the blobs
// tracked again from `predicted`; true when that gives a pose on >= 4 beacons whose residuals fit
// the noise (in loo_result_).
bool Tracker::LeaveOutFits(const BodyPose& predicted, const PoseBounds& bounds, double gate_px, const TrackOptions& o,
                           const BeaconSet& excluded, int a, int b) {
  BeaconSet without = excluded;
  without.Set(a);
  if (b >= 0) without.Set(b);
  matcher_.SetExcluded(without);
  ambiguity_refused_ = false;
  bool refuted = false;
  return TrackFrom(predicted, bounds, gate_px, o, &loo_result_, &refuted) && loo_result_.matches.num_beacons >= 4 &&
         ResidualsFitTheNoise(loo_result_.solve, o);
}

// How far another pose may lie from b and be the same: gate_sigmas of b's 1-sigma (centroid
// noise and the map's error), or 1 mm / 1 mrad when that is larger.
void Tracker::SameTolerance(const TrackResult& b, const TrackOptions& o, double* tol_m, double* tol_rad) const {
  SameTolerance(b.solve.has_covariance ? &b.solve.covariance : nullptr, o, tol_m, tol_rad);
}

void Tracker::SameTolerance(const Matrix6d* cov, const TrackOptions& o, double* tol_m, double* tol_rad) const {
  const double total = noise_.TotalToCentroid();
  *tol_m = std::max(1e-3, cov != nullptr ? o.gate_sigmas * total * PositionSigma(*cov) : 0.0);
  *tol_rad = std::max(1e-3, cov != nullptr ? o.gate_sigmas * total * AttitudeSigma(*cov) : 0.0);
}

bool Tracker::SamePoseWithin(const TrackResult& a, const TrackResult& b, const TrackOptions& o) const {
  double tol_m = 0.0, tol_rad = 0.0;
  SameTolerance(b, o, &tol_m, &tol_rad);
  return PoseWithin(a.pose, b.pose, tol_m, tol_rad);
}

// A pose from re-identification took each beacon's nearest blob within a tight gate; a
// reflection beside a beacon may have been taken instead, bending the pose (seen: a confirmed
// seven-beacon fix 23 mm off, its residuals 0.14 px). The pose goes through tracking's trials
// from itself, with hold_gate_px (reflections lie within tens of pixels) and bounds twin_m /
// twin_rad: false when they disagree; otherwise *r is the best trial when one is consistent.
bool Tracker::Unambiguous(const TrackOptions& o, TrackResult* r) {
  bool refuted = false;
  if (TrackFrom(r->pose, PoseBounds{o.twin_m, o.twin_rad}, o.hold_gate_px, o, &trial_result_, &refuted)) {
    // The trials verify the pose; they must not move it elsewhere: with the wide gate a
    // beacon's nearest blob may be a reflection while its true blob fails the trial (seen: an
    // acquired pose 5 mm off replaced by a trial on a reflection, 56 mm off, published as fix).
    if (!SamePoseWithin(trial_result_, *r, o)) {
      ambiguity_refused_ = true;
      return false;
    }
    r->pose = trial_result_.pose;
    r->matches = trial_result_.matches;
    r->solve = trial_result_.solve;
    return true;
  }
  return !ambiguity_refused_;
}

// Whether a stand-alone pose decides its identities (TrackOptions::identity_gate_chi2).
bool Tracker::IdentitiesDecided(const TrackOptions& o, const TrackResult& r) {
  if (!(o.identity_gate_chi2 > 0.0) || !r.solve.has_covariance) return true;
  if (IdentitiesDecisive(*rig_, r.pose, r.solve.covariance, o.solve.sigma_px, noise_.ResidualSigmaPx(), blobs_,
                         num_blobs_, r.matches.matches.data(), r.matches.num_matches, o.identity_gate_chi2))
    return true;
  ++counters_.identity_refused;
  return false;
}

// A tracked pose on four beacons or more whose beacon has a rival blob (IdentitiesDecisive) that
// explains the blobs clearly better (ambiguity_chi2) with the pose it gives takes it: tracking's
// gate, centred on the motion's prediction, held only the other blob. Seen with a wide camera,
// 76 beacons in one and a near one in the other: the near beacon's reflection 7 px away was
// tracked and moved the pose 3.5 mm, 26 of its 1-sigma (rival d2 0.9, the solve's chi-square
// 530 lower on it). A rival that fits about as well is left alone: the motion chose between
// them (tried: degrading those poses cost 1-3 % of the matrix's fixes, and every one was right).
void Tracker::TakeBetterRival(const TrackOptions& o, TrackResult* r) {
  if (!(o.identity_gate_chi2 > 0.0) || !r->solve.has_covariance || r->matches.num_beacons < 4) return;
  IdentityRival rival;
  if (IdentitiesDecisive(*rig_, r->pose, r->solve.covariance, o.solve.sigma_px, noise_.ResidualSigmaPx(), blobs_,
                         num_blobs_, r->matches.matches.data(), r->matches.num_matches, o.identity_gate_chi2, &rival))
    return;
  std::array<Match, limits::kMaxMatches> swapped{};
  const int n = r->matches.num_matches;
  for (int i = 0; i < n; ++i) {
    swapped[static_cast<std::size_t>(i)] = r->matches.matches[static_cast<std::size_t>(i)];
    if (swapped[static_cast<std::size_t>(i)].blob == rival.blob) swapped[static_cast<std::size_t>(i)].blob = rival.rival_blob;
  }
  if (SolvePose(*rig_, blobs_, num_blobs_, swapped.data(), n, r->pose, o.solve, &identity_solve_) != SolveStatus::kOk ||
      !(2.0 * (r->solve.cost - identity_solve_.cost) > o.ambiguity_chi2 * noise_.ResidualVariancePx2()) ||
      identity_solve_.num_beacons != r->matches.num_beacons || !identity_solve_.has_covariance ||
      !ResidualsFitTheNoise(identity_solve_, o))
    return;
  for (int i = 0; i < n; ++i) r->matches.matches[static_cast<std::size_t>(i)] = swapped[static_cast<std::size_t>(i)];
  r->pose = identity_solve_.pose;
  r->solve = identity_solve_;
  ++counters_.identity_swapped;
}

// A beacon with two blobs in its gate whose last accepted blob's image track continues, steady,
// into one of them while the other blob is new (age 1): the beacon takes that blob (moved from
// ambiguous_ to base_) instead of the trials of both. A reflection that appears beside a
// beacon for one frame set does not continue anything; one that moves with the scene is
// steady, and both blobs are still tried. (A beacon whose track was lost and whose blob is
// new beside a steady reflection that took its place is not resolved: the other is not new.)
void Tracker::ContinueTracks(const TrackOptions& o) {
  if (!o.continue_blob_tracks || steady_ == nullptr) return;
  int kept = 0;
  for (int i = 0; i < ambiguous_.num; ++i) {
    const AmbiguousMatch a = ambiguous_.items[static_cast<std::size_t>(i)];
    const std::uint32_t id = BeaconTrack(a.camera, a.beacon);
    // `own` continues the beacon's track and `other` is new.
    const auto continues = [&](int own, int other) {
      const bool known = (id != 0 && blob_tracks_.id(own) == id) ||
                         acquired_matches_.BeaconOfBlob(own) == a.beacon;
      return known && blob_tracks_.steady(own) && blob_tracks_.age(other) == 1;
    };
    const int blob = continues(a.blob_near, a.blob_far) ? a.blob_near : continues(a.blob_far, a.blob_near) ? a.blob_far : -1;
    if (blob >= 0 && base_.Add(Match{blob, a.beacon, a.camera})) {
      ++counters_.ambiguity_continued;
      continue;
    }
    ambiguous_.items[static_cast<std::size_t>(kept++)] = a;
  }
  ambiguous_.num = kept;
}

// Each matched beacon's blob track, for ContinueTracks at the next frame sets.
void Tracker::RememberTracks(const MatchSet& matches) {
  if (steady_ == nullptr) return;
  for (int i = 0; i < matches.num_matches; ++i) {
    const Match& m = matches.matches[static_cast<std::size_t>(i)];
    if (m.camera < 0 || m.camera >= limits::kMaxCameras || m.beacon < 0 || m.beacon >= limits::kMaxBeacons) continue;
    BeaconTrack(m.camera, m.beacon) = blob_tracks_.id(m.blob);
  }
}

// The steady blobs of this frame set whose track is a remembered beacon's (RememberTracks):
// their identity is known from the image alone, whatever the pose. Returns how many.
int Tracker::ContinuingBlobs(const TrackOptions& o) {
  num_continuing_ = 0;
  if (!o.continue_blob_tracks || steady_ == nullptr) return 0;
  for (int i = 0; i < num_blobs_; ++i) {
    if (!blob_tracks_.steady(i)) continue;
    const std::uint32_t id = blob_tracks_.id(i);
    const int camera = blobs_[i].camera;
    for (int b = 0; b < rig_->num_beacons; ++b) {
      if (BeaconTrack(camera, b) != id) continue;
      continuing_[static_cast<std::size_t>(num_continuing_++)] = ContinuingBlob{i, b};
      break;
    }
  }
  return num_continuing_;
}

// Near a recent pose, the blobs that continue the image tracks of beacons it identified are
// those beacons (ContinuingBlobs): lost-in-space then searches only the poses that keep them,
// a small fraction of the hypotheses, so that the search near a prediction whose bounds grew
// over a gap ends within the frame set's budget (seen: a 2 s gap with two beacons in view, then
// four; the truth found but the search cut every frame set for 100 frame sets). The same trust
// in the image tracks as Acquire's pruning of followed poses (KeepsContinuingBlobs).
// At most kMaxAnchors anchors: the oldest image tracks, cameras in turn (the wider the anchors,
// the better the poses they fix). Lost-in-space searches their triples (ten for five anchors,
// so that a degenerate triple or one wrong anchor still leaves the truth). When every pose is
// refuted, SettleLis looks without the prior.
void Tracker::AnchorContinuingBlobs(const TrackOptions& o, LisPrior* prior) {
  if (!o.anchor_blob_tracks || ContinuingBlobs(o) == 0) return;
  std::array<bool, limits::kMaxObservations> taken{};
  int n = 0;
  for (bool progress = true; progress && n < kMaxAnchors;) {
    progress = false;
    for (int k = 0; k < rig_->num_cameras && n < kMaxAnchors; ++k) {
      int best = -1;
      for (int i = 0; i < num_continuing_; ++i) {
        const int blob = continuing_[static_cast<std::size_t>(i)].blob;
        if (taken[static_cast<std::size_t>(i)] || blobs_[blob].camera != k) continue;
        if (best < 0 || blob_tracks_.age(blob) > blob_tracks_.age(continuing_[static_cast<std::size_t>(best)].blob))
          best = i;
      }
      if (best < 0) continue;
      taken[static_cast<std::size_t>(best)] = true;
      const ContinuingBlob& c = continuing_[static_cast<std::size_t>(best)];
      anchors_[static_cast<std::size_t>(n++)] = LisAnchor{c.blob, c.beacon};
      progress = true;
    }
  }
  prior->anchors = anchors_.data();
  prior->num_anchors = n;
  ++counters_.anchored_searches;
}

// Whether a pose names every continuing blob (ContinuingBlobs) its remembered beacon: a pose that
// explains such a blob as another beacon, or not at all, contradicts the image tracks.
bool Tracker::KeepsContinuingBlobs(const BodyPose& pose, const TrackOptions& o) {
  if (num_continuing_ == 0) return true;
  matcher_.MatchPose(pose, o.lis.refine_match, &twin_set_);
  for (int i = 0; i < num_continuing_; ++i) {
    const ContinuingBlob& c = continuing_[static_cast<std::size_t>(i)];
    if (twin_set_.BeaconOfBlob(c.blob) != c.beacon) return false;
  }
  return true;
}

// set_ = the unambiguous matches plus, for ambiguous beacon i < n, its nearer blob (bit i of
// choice clear) or its farther one (set). False when a blob would be used twice.
bool Tracker::ChooseAmbiguous(std::uint32_t choice, int n) {
  set_ = base_;
  for (int i = 0; i < n; ++i) {
    const AmbiguousMatch& a = ambiguous_.items[static_cast<std::size_t>(i)];
    const int blob = (choice >> i & 1U) != 0 ? a.blob_far : a.blob_near;
    if (!set_.Add(Match{blob, a.beacon, a.camera})) return false;
  }
  return true;
}

// Every consistent trial that explains the blobs about as well as best lies within gate_sigmas
// of best's 1-sigma (centroid noise and the map's error), or 1 mm / 1 mrad when that is
// smaller: which blob is right then makes no difference the covariance does not already state.
// A trial explains worse when it has fewer beacons (a wrong blob among four or more is often
// dropped by the solve's outlier rejection) or, with as many, a chi-square (residuals over the
// centroid noise and the map's error) above best's by ambiguity_chi2 (a wrong blob among
// four or more that the pose bent to fit); among three, every trial fits exactly.
// The largest distance of such a trial from best is kept (ambiguity_spread_m_ / _rad_).
bool Tracker::AgreeWith(const TrackResult& best, int num_trials, const TrackOptions& o) {
  const double var_px2 = noise_.ResidualVariancePx2();
  double tol_m = 0.0, tol_rad = 0.0;
  SameTolerance(best, o, &tol_m, &tol_rad);
  ambiguity_spread_m_ = ambiguity_spread_rad_ = 0.0;
  for (int i = 0; i < num_trials; ++i) {
    const Trial& t = trials_[static_cast<std::size_t>(i)];
    if (t.beacons < best.matches.num_beacons) continue;
    if (2.0 * (t.cost - best.solve.cost) > o.ambiguity_chi2 * var_px2) continue;
    ambiguity_spread_m_ = std::max(ambiguity_spread_m_, (t.pose.r_w_wb - best.pose.r_w_wb).norm());
    ambiguity_spread_rad_ = std::max(ambiguity_spread_rad_, LogSO3(best.pose.C_w_b.transpose() * t.pose.C_w_b).norm());
  }
  return ambiguity_spread_m_ <= tol_m && ambiguity_spread_rad_ <= tol_rad;
}

// Tracking's trials disagreed (a reflection beside a beacon that fits as well as the beacon),
// but all of them lie near the prediction: the pose is known to within their spread, so the
// best trial is published degraded (reason kAmbiguous) with that spread added to its
// covariance, so that its 1-sigma covers whichever trial is true; while the spread stays within
// ambiguity_max_spread_m / _rad. The motion model is not fed from it: the next frame set is
// predicted from the last accepted pose (coasting), whose bounds grow with the gap.
bool Tracker::PublishAmbiguous(const TrackOptions& o, TrackResult* r) {
  if (!(ambiguity_spread_m_ <= o.ambiguity_max_spread_m) || !(ambiguity_spread_rad_ <= o.ambiguity_max_spread_rad) ||
      !r->solve.has_covariance)
    return false;
  // Its identities are those not in doubt: the beacons tried with two blobs are left out.
  r->matches.Retain([&](int, const Match& m) {
    for (int k = 0; k < ambiguous_.num; ++k)
      if (ambiguous_.items[static_cast<std::size_t>(k)].beacon == m.beacon &&
          ambiguous_.items[static_cast<std::size_t>(k)].camera == m.camera)
        return false;
    return true;
  });
  for (int d = 0; d < 3; ++d) {
    r->solve.covariance(d, d) += ambiguity_spread_m_ * ambiguity_spread_m_;
    r->solve.covariance(d + 3, d + 3) += ambiguity_spread_rad_ * ambiguity_spread_rad_;
  }
  ++counters_.ambiguous_published;
  RememberTracks(r->matches);
  PublishUnfollowed(r);
  return true;
}

// A tracked pose published degraded (reason kAmbiguous) without feeding the motion model.
void Tracker::PublishUnfollowed(TrackResult* r) {
  r->status = TrackStatus::kDegraded;
  r->reason = TrackReason::kAmbiguous;
  r->source = TrackSource::kTracked;
  CountOutcome(*r);
}

// Tracking's trials disagreed by more than PublishAmbiguous covers: the motion decides when one
// trial lies near the Kalman filter's prediction (squared Mahalanobis distance, its covariance
// plus the trial's for the centroid noise and the map's error, at most ambiguity_accept_m2) and
// every trial that is not the same pose lies far from it (ambiguity_reject_m2 or more). *r is
// then that trial, solved again; the caller publishes it degraded (Accept does not follow it).
bool Tracker::DecideByMotion(const BodyPose& predicted, const PoseBounds& bounds, const TrackOptions& o,
                             TrackResult* r) {
  const PoseFilter& f = motion_.filter();
  if (!(o.ambiguity_accept_m2 > 0.0) || !f.started() || num_trials_ < 2) return false;
  const double k2 = noise_.TotalToCentroid() * noise_.TotalToCentroid();
  int nearest = -1;
  double best = 0.0;
  std::array<double, kMaxTrials> m2{};
  for (int i = 0; i < num_trials_; ++i) {
    const Trial& t = trials_[static_cast<std::size_t>(i)];
    m2[static_cast<std::size_t>(i)] = f.Distance2(t.pose, k2 * t.cov, now_ns_);
    if (nearest < 0 || m2[static_cast<std::size_t>(i)] < best) {
      nearest = i;
      best = m2[static_cast<std::size_t>(i)];
    }
  }
  if (!(best <= o.ambiguity_accept_m2)) return false;
  const Trial& chosen = trials_[static_cast<std::size_t>(nearest)];
  double tol_m = 0.0, tol_rad = 0.0;
  SameTolerance(&chosen.cov, o, &tol_m, &tol_rad);
  for (int i = 0; i < num_trials_; ++i) {
    const Trial& t = trials_[static_cast<std::size_t>(i)];
    if (!PoseWithin(t.pose, chosen.pose, tol_m, tol_rad) && !(m2[static_cast<std::size_t>(i)] >= o.ambiguity_reject_m2)) return false;
  }
  // The chosen trial again, for its matches and solve (trials_ keeps only the pose).
  bool refuted = false;
  double innovation = -1.0;
  if (!ChooseAmbiguous(chosen.choice, std::min(ambiguous_.num, o.max_ambiguous_tried))) return false;
  SolveTracked(predicted, bounds, o, r, &refuted, &innovation);
  return r->solve.has_covariance && innovation >= 0.0 && innovation <= o.ambiguity_innovation_factor &&
         (r->pose.r_w_wb - chosen.pose.r_w_wb).norm() <= tol_m;
}

// The tracking gate (px) around every predicted beacon: the base gate (gate_px with a velocity,
// hold_gate_px without), the motion since the last pose beyond its slack (the acceleration or
// speed bounds, as the image motion of a beacon at gate_depth_m), and gate_sigmas of the last
// pose's error. *gate counts the centroid noise's share, *with_map also the map's error (a bias
// the frame sets that see the same beacons share: a beacon entering the view lands that much
// off; seen: 20 px after three-beacon poses of a 0.4 mm survey).
// The pose's error is projected into the images at the prediction (its covariance grown by the
// velocity's lead; the largest over the beacons predicted in the delivered cameras) when the
// last pose was a fix on four beacons or more and is recent (within velocity_window_s): then
// its linearised covariance holds, and it moves the beacons the pose was solved from by about
// the centroid noise, where a position error seen at gate_depth_m plus an independent attitude
// error counts the pose's correlated errors twice and the beacons' range as the nearest
// possible (a narrower gate holds fewer reflections beside beacons: with it the acquisition
// matrix's 64-beacon box posed 92.1 % of its frame sets after the first fix, 91.7 % without,
// and on unseen seeds one wrong degraded pose less; docs/acquisition.md, session 18).
// Otherwise it counts as a position error seen at gate_depth_m plus an attitude error, and a
// wide gate sends the frame set to re-identification (lost-in-space near the prediction, every
// consistent pose listed), which three-beacon tracking in a narrow gate would bypass: a degraded pose's covariance may lie
// (near the P3P's degenerate configurations, seen 37 mm off at 17 of its 1-sigma), and a
// spurious blob in a narrow gate fits three beacons exactly (seen: 56 mm and 2.4 deg off after
// 0.4 s with two beacons; 56 mm and 1.7 deg off one frame set after a three-beacon fix 7 mm
// uncertain, on the matrix's unseen seeds).
void Tracker::PredictionGatePx(const BodyPose& predicted, double since_s, const TrackOptions& o, double* gate,
                               double* with_map) const {
  const double px = noise_.px_per_rad;
  const double base = motion_.has_velocity() ? o.gate_px : o.hold_gate_px;
  // Pose-space bounds beyond the slack, as the image motion of a beacon at gate_depth_m.
  const auto bounds_px = [&](const PoseBounds& b) {
    return px * ((b.max_rad - o.innovation_rad) + (b.max_m - o.innovation_m) / o.gate_depth_m);
  };
  if (!o.projected_gate || !last_fix_ || since_s > o.velocity_window_s) {
    *gate = base + bounds_px(motion_.Bounds(since_s, limits_.motion));
    const double map_rad = motion_.last_map_sigma_rad(), map_m = motion_.last_map_sigma_m();
    *with_map = *gate + o.gate_sigmas * px * (map_rad + map_m / o.gate_depth_m);
    return;
  }
  MotionLimits motion_only = limits_.motion;
  motion_only.sigmas = 0.0;
  const double motion_px = base + bounds_px(motion_.Bounds(since_s, motion_only));
  const double image_sigma = ImageSigmaPx(predicted, motion_.last_cov());
  const double lead = motion_.Lead(since_s), ratio = noise_.MapToCentroidRatio();
  *gate = motion_px + o.gate_sigmas * lead * image_sigma;
  *with_map = motion_px + o.gate_sigmas * std::sqrt(lead * lead + ratio * ratio) * image_sigma;
}

// The largest image 1-sigma (px, the larger axis) that a pose error of covariance cov
// (PoseDelta order) gives a beacon predicted in a delivered camera's image at `pose`.
double Tracker::ImageSigmaPx(const BodyPose& pose, const Matrix6d& cov) const {
  double worst = 0.0;
  for (int k = 0; k < rig_->num_cameras; ++k) {
    if ((cameras_ >> k & 1u) == 0) continue;
    const RigCamera& cam = rig_->cameras[static_cast<std::size_t>(k)];
    for (int b = 0; b < rig_->num_beacons; ++b) {
      const Eigen::Vector3d& P_w = rig_->beacons_w[static_cast<std::size_t>(b)];
      Eigen::Vector2d uv;
      bool inner = false;
      if (!matcher_.Predict(k, pose, P_w, 0.0, 0.0, &uv, &inner)) continue;
      Eigen::Matrix<double, 2, 6> J;
      if (ProjectBeacon(cam, pose, P_w, &uv, &J) != ProjectStatus::kOk) continue;
      const Eigen::Matrix2d S = J * cov * J.transpose();
      // Largest eigenvalue of the symmetric 2x2.
      const double half_trace = 0.5 * (S(0, 0) + S(1, 1));
      const double d = 0.5 * (S(0, 0) - S(1, 1));
      worst = std::max(worst, half_trace + std::sqrt(d * d + S(0, 1) * S(0, 1)));
    }
  }
  return std::sqrt(worst);
}

// One trial: solve from the prediction with the identities in set_, then the innovation test.
// *innovation: the solved pose's distance from the prediction over the allowed one (the larger
// of position and attitude; > 1: refused), -1 when it did not solve.
bool Tracker::SolveTracked(const BodyPose& predicted, const PoseBounds& bounds, const TrackOptions& o, TrackResult* r,
                           bool* refuted, double* innovation) {
  *refuted = false;
  *innovation = -1.0;
  const TwinRegion region{&predicted, bounds.max_m, bounds.max_rad};
  if (!SolveAt(predicted, region, o, r)) {
    *refuted = UnexcusedMissing(r->matches, o.lis) > o.max_missing || r->solve.rms_px > o.max_rms_px;
    return false;
  }
  // Innovation test: the solved pose must be where the motion model allows. Three matches
  // fit any pose exactly, so one wrong match (a spurious blob in a beacon's gate) shows only
  // here, as a jump. (Not a refutation of the prior: a wrong match proves nothing about it.)
  double allow_m = bounds.max_m, allow_rad = bounds.max_rad;
  if (noise_.map_error_px > 0.0 && r->solve.has_covariance) {
    // The solved pose's own error for the map's error (its covariance is for sigma_px).
    const double scale = noise_.TotalToCentroid();
    allow_m += o.gate_sigmas * scale * PositionSigma(r->solve.covariance);
    allow_rad += o.gate_sigmas * scale * AttitudeSigma(r->solve.covariance);
  }
  *innovation = std::max((r->pose.r_w_wb - predicted.r_w_wb).norm() / allow_m,
                         LogSO3(predicted.C_w_b.transpose() * r->pose.C_w_b).norm() / allow_rad);
  if (*innovation > 1.0) {
    ++counters_.innovation_refused;
    return false;
  }
  return true;
}


// Readies the followed poses for frame t_ns (Acquisition::Prepare; the last accepted pose seeds
// them within max_seed_s) and makes them lost-in-space's prior: false when there are none.
bool Tracker::ChainPrior(std::uint64_t t_ns, const TrackOptions& o, LisPrior* prior) {
  const bool may_seed = motion_.known() && Seconds(t_ns, motion_.last_t_ns()) <= o.max_seed_s;
  acquisition_.Prepare(t_ns, limits_, may_seed ? &motion_ : nullptr);
  return acquisition_.Prior(prior);
}

// Follows the poses kept so far with lost-in-space's (complete) consistent poses of this frame
// set (Acquisition::Follow). The true pose is in every complete list when three true beacons are
// in view; with fewer, spurious blobs can still make three blobs, and the truth may drop out:
// hence min_acquire_frames for chains not seeded by an accepted pose. True: the one pose left
// is accepted, solved in *r.
bool Tracker::Acquire(std::uint64_t t_ns, const TrackOptions& o, TrackResult* r) {
  const LisResult& l = lis_res_;
  if (!l.complete && !l.steady_complete) {
    r->acquisition_poses = acquisition_.size();
    return false;  // no information this frame: the followed poses coast
  }
  if (acquisition_.empty()) {
    acquisition_.Start(l, t_ns);
    KeepSteadyChain(l, o);
    r->acquisition_poses = acquisition_.size();
    return false;
  }
  // Emptied when nothing is consistent near the followed poses: none was the truth, or this
  // frame set has fewer than 3 true beacons (e.g. 2 and a reflection). It starts over at the
  // next frame set: from the prediction again while the last accepted pose may seed it (a
  // refuted prediction is forgotten by Track, from its missing beacons), else without a prior.
  acquisition_.Follow(l, t_ns);
  KeepSteadyChain(l, o);
  // A followed pose that names a blob continuing a beacon's image track another beacon (or
  // leaves it unexplained) is not the truth, when the track was that beacon's in an accepted
  // pose: after a gap with fewer than three beacons, the two that stayed in view keep their
  // identities, and poses resting on spurious blobs in their place drop out.
  if (acquisition_.seeded() && ContinuingBlobs(o) > 0)
    counters_.continuity_refuted += static_cast<std::uint32_t>(
        acquisition_.Retain([&](const BodyPose& p) { return KeepsContinuingBlobs(p, o); }));
  if (acquisition_.seeded() && o.prune_to_steady) counters_.steady_pruned += static_cast<std::uint32_t>(PruneToSteady(o));
  r->acquisition_poses = acquisition_.size();
  // The last pose must be confirmed by this frame set. A chain seeded by an accepted pose
  // holds the truth when the frame sets had three true beacons; one started from
  // lost-in-space alone may not (its first frame set may have had fewer), so it must outlive
  // min_acquire_frames frame sets. So must a seeded one when reflections are in view (blobs
  // that the pose leaves unexplained, now or in the previous frame set): two true beacons
  // and a reflection fit an exact pose, which may be the one left in wide bounds (seen after
  // a 2 s gap: 0.2 rad off).
  if (acquisition_.size() != 1 || acquisition_.frames() < 2) return false;
  const BodyPose survivor = acquisition_.pose(0);
  // Carried back to the previous frame set, a pose resting on a reflection predicts its
  // beacon where that frame set has no blob (a reflection does not move with the body).
  int unexplained_prev = 0;
  if (!ExplainsPrevious(survivor, t_ns, o, &unexplained_prev)) {
    ++counters_.previous_refused;
    return false;
  }
  matcher_.MatchPose(survivor, o.lis.refine_match, &set_);
  const bool reflections = indexed_blobs_ > set_.num_matches || unexplained_prev > 0;
  // (A seeded chain counts its seed as the first frame.)
  const bool seeded = acquisition_.seeded();
  // A seeded survivor on four beacons or more needs no more frame sets with reflections in
  // view: its residuals have degrees of freedom, and the chi-square test below refuses a
  // reflection among them (acquisition matrix: 64-beacon box 92.1 -> 92.7 % posed after the
  // first fix, no wrong pose, also with static reflections; docs/acquisition.md, session 28).
  const bool waits = reflections && set_.num_beacons < 4;
  // A steady chain's survivor has explained four steady blobs within the noise in each of
  // min_acquire_frames frame sets; every pose that did in the first was followed. (There is no
  // complete list of this frame set to compare it with: SurvivorIsBest.)
  const bool steady = acquisition_.steady();
  const int needed = steady ? o.min_acquire_frames : seeded ? 1 + (waits ? o.min_acquire_frames : 1) : o.min_acquire_frames;
  if (acquisition_.frames() < needed) return false;
  if (!seeded && !steady && !SurvivorIsBest(t_ns, o)) return false;
  // One pose left: its identities, solved.
  // Lost-in-space listed every consistent pose within the bounds, so a second P3P root there
  // would be a second survivor; unseeded, a root within twin_m / twin_rad is refused.
  const TwinRegion twin = seeded ? TwinRegion{nullptr, o.lis.same_pose_m, o.lis.same_pose_rad}
                                 : TwinRegion{nullptr, o.twin_m, o.twin_rad};
  if (set_.num_beacons < 3 || !SolveAt(survivor, twin, o, r)) return false;
  if (!ResidualsFitTheNoise(r->solve, o)) {  // four beacons or more, one of them a blob beside it
    ++counters_.residual_refused;
    return false;
  }
  // Unambiguous's trials keep the survivor's blobs where the alternative is a new blob (a
  // reflection flickering beside its beacon: both fit three beacons exactly, and the trials'
  // tie-break would pick either; seen: 32 mm off, published as fix).
  acquired_matches_ = r->matches;
  // With reflections in view, a three-beacon pose on a blob that continues no image track may
  // rest on a reflection flickering beside a beacon (it fits exactly all the same; seen: 20-32
  // mm off, published as fix, the truth dropped from the chain): it waits until its blobs are
  // steady (two frame sets for a beacon that has just come into view).
  if (reflections && r->matches.num_beacons == 3 && !OnSteadyBlobs(r->matches)) {
    ++counters_.unsteady_refused;
    return false;
  }
  // Three beacons fit their pose exactly, and the motion refutes a pose resting on a reflection
  // only when the reflection jumps: one that moves with the scene (a point on a wall) keeps a
  // wrong three-beacon pose consistent frame set after frame set (seen: a seeded chain's
  // survivor 147 mm and 10 deg off, on one beacon and two such reflections, while the true
  // pose had dropped out of the chain). A steady blob it leaves unexplained (a fourth beacon,
  // or such a reflection) is the sign: wait for the pose that explains it.
  if (r->matches.num_beacons == 3 && LeavesSteadyBlob(r->matches)) {
    ++counters_.steady_unexplained;
    return false;
  }
  acquisition_.Clear();
  return true;
}

// A seeded chain holding one pose on steady blobs only (three beacons or more) and others that
// each name a new blob (a track of one frame set: a reflection flickering beside a beacon)
// keeps the one (TrackOptions::prune_to_steady). Returns how many poses were dropped.
// A reflection beside a beacon takes that beacon's place in the pose that names it, so the two
// explain as many beacons; a pose on a new blob that explains more than the steady one has a
// beacon just come into view, and is kept (seen: half-resolution rig, the steady pose on three
// beacons 535 mm and 18 deg off, the truth on four with the fourth's first blob, published).
int Tracker::PruneToSteady(const TrackOptions& o) {
  if (steady_ == nullptr || acquisition_.size() < 2) return 0;
  int on_steady = 0, kept = -1, kept_beacons = 0, most_on_new = 0;
  for (int i = 0; i < acquisition_.size(); ++i) {
    matcher_.MatchPose(acquisition_.pose(i), o.lis.refine_match, &set_);
    if (set_.num_beacons >= 3 && OnSteadyBlobs(set_)) {
      ++on_steady;
      kept = i;
      kept_beacons = set_.num_beacons;
    } else if (OnNewBlob(set_)) {
      most_on_new = std::max(most_on_new, set_.num_beacons);
    } else {
      return 0;  // a pose that is neither: nothing tells them apart
    }
  }
  if (on_steady != 1 || most_on_new > kept_beacons) return 0;
  const BodyPose keep = acquisition_.pose(kept);
  return acquisition_.Retain(
      [&](const BodyPose& p) { return p.r_w_wb == keep.r_w_wb && p.C_w_b == keep.C_w_b; });
}

// A chain followed from a steady list (LisResult::steady_complete; never complete) keeps the
// poses on four steady blobs (OnFourSteadyBlobs), as does one followed from such a list before.
void Tracker::KeepSteadyChain(const LisResult& list, const TrackOptions& o) {
  if (list.steady_complete) acquisition_.MarkSteady();
  if (!acquisition_.steady()) return;
  counters_.steady_refuted += static_cast<std::uint32_t>(
      acquisition_.Retain([&](const BodyPose& p) { return OnFourSteadyBlobs(p, o); }));
}

// Whether a pose explains steady blobs (BlobTracks) with four distinct beacons or more, misses
// none, and its solve on all it explains fits the noise (ResidualsFitTheNoise: four beacons
// leave two degrees of freedom, which a wrong pose fits only roughly).
bool Tracker::OnFourSteadyBlobs(const BodyPose& pose, const TrackOptions& o) {
  if (steady_ == nullptr) return false;
  matcher_.MatchPose(pose, o.lis.refine_match, &set_);
  if (UnexcusedMissing(set_, o.lis) > o.lis.max_missing) return false;
  BeaconSet on_steady;
  for (int m = 0; m < set_.num_matches; ++m) {
    const Match& x = set_.matches[static_cast<std::size_t>(m)];
    if (steady_[x.blob] != 0) on_steady.Set(x.beacon);
  }
  if (on_steady.Count() < 4) return false;
  return SolvePose(*rig_, blobs_, num_blobs_, set_.matches.data(), set_.num_matches, pose, o.lis.solve,
                   &identity_solve_) == SolveStatus::kOk &&
         ResidualsFitTheNoise(identity_solve_, o);
}

// Whether the search just begun (lis_res_) should list the poses on four steady blobs instead
// (TrackOptions::steady_lists): four steady blobs or more, and a list of every pose that cannot
// be had within its work units.
bool Tracker::WantsSteadyList(const TrackOptions& o) {
  const int steady = SteadyBlobs();
  return o.steady_lists && steady >= 4 && steady <= o.lis.confirm_beacons && !lis_.MayComplete(&lis_res_);
}

// Begins again, as a steady list (LisOptions::steady_list), the search just begun with options
// lo: the first one's count (MayComplete) charged.
LisStatus Tracker::BeginSteadyList(const BlobObs* blobs, int num_blobs, LisOptions lo, const LisPrior* prior) {
  Charge(lis_res_.cost);
  lo.steady_list = true;
  const LisStatus s = lis_.Begin(blobs, num_blobs, lo, &lis_res_, prior, cameras_, steady_);
  counters_.steady_lists += lis_.steady_list() ? 1U : 0U;
  return s;
}

// Whether some matched blob began its image track in this frame set.
bool Tracker::OnNewBlob(const MatchSet& matches) const {
  for (int m = 0; m < matches.num_matches; ++m)
    if (blob_tracks_.age(matches.matches[static_cast<std::size_t>(m)].blob) == 1) return true;
  return false;
}

// Whether every matched blob is steady (BlobTracks); true without blob tracks.
bool Tracker::OnSteadyBlobs(const MatchSet& matches) const {
  if (steady_ == nullptr) return true;
  for (int m = 0; m < matches.num_matches; ++m)
    if (!blob_tracks_.steady(matches.matches[static_cast<std::size_t>(m)].blob)) return false;
  return true;
}

// Whether a steady blob (BlobTracks) of a camera that delivered is not among the matches.
bool Tracker::LeavesSteadyBlob(const MatchSet& matches) const {
  if (steady_ == nullptr) return false;
  for (int i = 0; i < num_blobs_; ++i) {
    if (steady_[i] == 0 || (cameras_ >> blobs_[i].camera & 1u) == 0) continue;
    if (matches.BeaconOfBlob(i) < 0) return true;
  }
  return false;
}

// Whether a solved pose's residuals are the noise its covariance assumes: their chi-square
// (the squared residuals over noise_'s residual variance) within the upper quantile of
// residual_test_sigmas (one-sided normal) for 2 N - 6 degrees of freedom (Wilson-Hilferty).
// Four beacons or more fit a wrong pose only approximately (seen: a lost-in-space fix on two
// beacons and two reflections beside them, 2.4 m off, at 0.74 px RMS against 0.1 px noise; the
// RMS bound of a fix, fix_rms_sigmas, let it pass as fix).
bool Tracker::ResidualsFitTheNoise(const SolveResult& s, const TrackOptions& o) const {
  const int dof = 2 * s.num_inliers - 6;
  if (!(o.residual_test_sigmas > 0.0) || dof <= 0) return true;
  const double chi2 = 2.0 * s.cost / noise_.ResidualVariancePx2();
  const double k = dof, a = 2.0 / (9.0 * k);
  const double quantile = k * std::pow(1.0 - a + o.residual_test_sigmas * std::sqrt(a), 3);
  return chi2 <= quantile;
}

// An unseeded chain started from lost-in-space's list of its first frame set; when that frame
// set had fewer than three true beacons, the truth was never followed and a pose that fits
// the same blobs (an alias) may be the one left (seen: it explained three of four blobs, the
// truth four). So the survivor must score best among every pose consistent with this frame
// set (lost-in-space without a prior, complete); otherwise the chain restarts from that list.
bool Tracker::SurvivorIsBest(std::uint64_t t_ns, const TrackOptions& o) {
  ++counters_.lis_runs;
  RunLis(blobs_, num_blobs_, nullptr, o);
  const LisResult& l = lis_res_;
  if (!l.complete) return false;  // cannot tell now: keep following
  const BodyPose& s = acquisition_.pose(0);
  double survivor = -1e300, others = -1e300;
  for (int i = 0; i < l.num_consistent; ++i) {
    const BodyPose& p = l.consistent_poses[static_cast<std::size_t>(i)];
    const bool same = (p.r_w_wb - s.r_w_wb).norm() <= o.lis.same_pose_m &&
                      LogSO3(s.C_w_b.transpose() * p.C_w_b).norm() <= o.lis.same_pose_rad;
    double& score = same ? survivor : others;
    score = std::max(score, l.consistent_scores[static_cast<std::size_t>(i)]);
  }
  if (survivor >= others) return true;
  acquisition_.Start(l, t_ns);
  ++counters_.chain_restarts;
  return false;
}

bool Tracker::ExplainsPrevious(const BodyPose& pose, std::uint64_t t_ns, const TrackOptions& o,
                               int* unexplained) {
  *unexplained = 0;
  if (prev_num_blobs_ < 0) return true;  // nothing kept (start): the chain's length must do
  const double dt = Seconds(t_ns, prev_t_ns_);
  if (!(dt > 0.0) || dt > o.velocity_window_s) return true;
  // Back along the velocity estimate; its error is what the accelerations may have changed
  // since the last accepted pose (or the speed bounds without a velocity).
  double dv_m = 0.0, dv_rad = 0.0;
  const BodyPose back = motion_.CarryBack(pose, t_ns, dt, limits_.motion, &dv_m, &dv_rad);
  const double gate = o.gate_px + noise_.px_per_rad * (dv_rad * dt + dv_m * dt / o.gate_depth_m);
  const int indexed = matcher_.SetBlobs(prev_blobs_.data(), prev_num_blobs_, prev_cameras_);
  // (A true beacon predicted just inside may really have been just outside: a refusal, never
  // a wrong fix; the next frame set decides.)
  matcher_.MatchPose(back, MatchOptions{gate, o.miss_margin_px, false}, &twin_set_);
  matcher_.SetBlobs(blobs_, num_blobs_, cameras_);
  *unexplained = std::max(0, indexed - twin_set_.num_matches);
  return twin_set_.num_missing <= o.max_missing;
}

// Whether a solved pose's whole 1-sigma (centroid noise and the map's error: the covariance
// Navigator publishes) exceeds a fix's bounds (max_position_sigma_m, max_attitude_sigma_rad),
// or it has none: such a pose is never a fix.
bool Tracker::BeyondFixSigmas(const SolveResult& s, const TrackOptions& o) const {
  if (!s.has_covariance) return true;
  const double total = noise_.TotalToCentroid();
  return total * PositionSigma(s.covariance) > o.max_position_sigma_m ||
         total * AttitudeSigma(s.covariance) > o.max_attitude_sigma_rad;
}

// Keeps this frame set's blobs for ExplainsPrevious at the next one.
void Tracker::KeepBlobs(std::uint64_t t_ns) {
  prev_num_blobs_ = std::min(num_blobs_, limits::kMaxObservations);
  for (int i = 0; i < prev_num_blobs_; ++i) prev_blobs_[static_cast<std::size_t>(i)] = blobs_[i];
  prev_t_ns_ = t_ns;
  prev_cameras_ = cameras_;
}

// The pose in *r is accepted: it feeds the motion model, ends the acquisition, and is judged
// fix or degraded.
void Tracker::Accept(std::uint64_t t_ns, const TrackOptions& o, TrackResult* r) {
  // The track goes on (keeping its verification) when tracking continued it, when a pose given
  // by SetPose seeded it, or when the last pose was accepted within velocity_window_s (a
  // re-identification near it: the prediction's bounds are a few centimetres).
  const bool continues = r->source == TrackSource::kTracked || given_seed_ ||
                         (motion_.known() && Seconds(t_ns, motion_.last_t_ns()) <= o.velocity_window_s);
  // The frame set before carried no pose (and no given one seeds this): a gap.
  const bool after_gap = !given_seed_ && !(motion_.known() && motion_.last_t_ns() == prev_t_ns_);
  const double sigma_m = r->solve.has_covariance ? PositionSigma(r->solve.covariance) : 0.0;
  const double sigma_rad = r->solve.has_covariance ? AttitudeSigma(r->solve.covariance) : 0.0;
  motion_.Add(r->pose, t_ns, sigma_m, sigma_rad, noise_.MapToCentroidRatio(), limits_.motion,
              r->solve.has_covariance ? &r->solve.covariance : nullptr);
  has_pose_ = true;
  acquisition_.Clear();
  lis_owner_ = LisOwner::kNone;  // (a search near the followed poses has nothing left to follow)
  // Three beacons fit their pose exactly: a new track is verified only by a pose with residuals
  // to test (verify_three_beacons).
  if (!continues) verified_ = false;
  given_seed_ = false;
  if (!verified_ && r->matches.num_beacons >= 4 && r->solve.has_covariance && ResidualsFitTheNoise(r->solve, o))
    verified_ = true;
  RememberTracks(r->matches);
  r->status = TrackStatus::kDegraded;
  if (r->matches.num_beacons < o.fix_min_beacons) r->reason = TrackReason::kFewBeacons;
  else if (r->solve.rms_px > o.degraded_rms_px || r->solve.rms_px > o.fix_rms_sigmas * noise_.ResidualSigmaPx())
    r->reason = TrackReason::kLargeResidual;
  else if (BeyondFixSigmas(r->solve, o))
    r->reason = TrackReason::kLargeCovariance;
  else if (o.verify_three_beacons && !verified_)
    r->reason = TrackReason::kUnverified;
  else if (o.three_beacon_fix_steady && r->matches.num_beacons == 3 && !OnSteadyBlobs(r->matches) &&
           (after_gap || LeavesSteadyBlob(r->matches)))
    r->reason = TrackReason::kUnverified;  // an identity neither the last pose nor the image carries
  else if (r->left_out_beacon >= 0)
    r->reason = TrackReason::kLargeResidual;  // the pose on every beacon was refused or did not fit
  else {
    r->status = TrackStatus::kFix;
    r->reason = TrackReason::kNone;
  }
  last_fix_ = r->status == TrackStatus::kFix && r->matches.num_beacons >= 4;
  switch (r->source) {
    case TrackSource::kTracked: ++counters_.tracked; break;
    case TrackSource::kLostInSpace: ++counters_.lost_in_space_fixes; break;
    case TrackSource::kAcquired: ++counters_.acquired; break;
    case TrackSource::kNone:
    case TrackSource::kCount: break;
  }
}

TrackStatus Tracker::Publish(TrackSource source, std::uint64_t t_ns, const TrackOptions& o, TrackResult* r) {
  r->source = source;
  view_repeated_ = false;
  if (source == TrackSource::kTracked) TakeBetterRival(o, r);
  Accept(t_ns, o, r);
  CountOutcome(*r);
  return r->status;
}

void Tracker::CountOutcome(const TrackResult& r) {
  ++counters_.by_status[static_cast<std::size_t>(r.status)];
  ++counters_.by_reason[static_cast<std::size_t>(r.reason)];
}

TrackStatus Tracker::Lost(TrackReason why, TrackResult* r) {
  // A search that refused poses because the map holds a copy of their beacons says why no pose
  // is decided better than "ambiguous": no motion or waiting tells a view from its exact copy.
  const bool undecided = why == TrackReason::kAmbiguous || why == TrackReason::kAcquiring ||
                         why == TrackReason::kBudgetExhausted || why == TrackReason::kNoHypothesis;
  if (undecided && r->lis_run && view_repeated_) why = TrackReason::kRepeatedView;
  r->status = TrackStatus::kLost;
  r->reason = why;
  r->source = TrackSource::kNone;
  r->matches.num_matches = 0;
  r->matches.num_beacons = 0;
  CountOutcome(*r);
  return r->status;
}

TrackStatus Tracker::Track(const BlobObs* blobs, int num_blobs, std::uint64_t t_ns, const TrackOptions& o,
                           TrackResult* r, std::uint32_t cameras) {
  cameras_ = cameras;
  ambiguity_refused_ = false;
  // The noise model's image noise and the motion bounds are those of this call's options.
  noise_ = noise_.WithImageNoise(o.solve.sigma_px, o.map_error_px);
  limits_ = LimitsOf(o);
  // One budget for the frame set, also when a finished cold search seeds it again (TrackOnce).
  lis_budget_left_ = o.lis_budget_per_frame;
  steady_ = nullptr;
  if (o.steady_blobs_first && rig_ != nullptr && o.IsValid()) {
    blob_tracks_.Update(blobs, num_blobs, t_ns, cameras, noise_.px_per_rad, BlobTrackOptionsOf(o));
    steady_ = blob_tracks_.steady_flags();
  }
  const TrackStatus s = TrackOnce(blobs, num_blobs, t_ns, o, r);
  if (r->reason != TrackReason::kBadInput) KeepBlobs(t_ns);
  return s;
}


// Lost-in-space within what is left of this frame set's budget (TrackOptions::
// lis_budget_per_frame, over every search of the frame set): the frame deadline holds whatever
// the map. A search cut by it reports kBudgetExhausted, never a guess.
LisStatus Tracker::RunLis(const BlobObs* blobs, int num_blobs, const LisPrior* prior, const TrackOptions& o) {
  if (rig_->num_beacons < o.lis.fourth_blob_min_beacons) return RunSmallMapLis(blobs, num_blobs, prior, o);
  if (lis_budget_left_ <= 0.0) {
    lis_res_.status = LisStatus::kBudgetExhausted;
    lis_res_.complete = false;
    lis_res_.confirmed = false;
    lis_res_.num_consistent = 0;
    return lis_res_.status;
  }
  LisOptions lo = o.lis;
  lo.max_cost = lis_budget_left_;
  lis_owner_ = LisOwner::kNone;  // (Identify abandons a search under way)
  const LisStatus s = lis_.Identify(blobs, num_blobs, lo, &lis_res_, prior, cameras_, steady_);
  Charge(lis_res_.cost);
  view_repeated_ = lis_res_.repeats > 0;
  return s;
}

// A small map's acquisition follows complete lists of three-beacon poses, which a search cut
// by the frame set's budget would not give (the paper yaw sweep with two spurious blobs: lists
// of 12 000-16 000 units; cut at 8 000, its first fix 43 -> 103 frame sets). So a search runs
// past the budget while its list may still be complete (LostInSpace::MayComplete); once the
// list has overflowed (a pose that may be consistent dropped), or its beacon triples are more
// than its work units allow, only a confirmed fix can come of it, and it stops where the
// budget does (seen: 16-beacon stations with 8 blobs a frame set, whose searches overflowed
// or ran to their 20 000 work units, 20-40 ms, every frame set).
LisStatus Tracker::RunSmallMapLis(const BlobObs* blobs, int num_blobs, const LisPrior* prior, const TrackOptions& o) {
  // Work between two looks at the list (cost units): small against the budget.
  constexpr double kSmallMapStep = 500.0;
  lis_owner_ = LisOwner::kNone;
  LisStatus s = lis_.Begin(blobs, num_blobs, o.lis, &lis_res_, prior, cameras_, steady_);
  while (s == LisStatus::kSearching) {
    const double left = lis_budget_left_ - lis_res_.cost;
    const bool may_complete = left > 0.0 || lis_.MayComplete(&lis_res_);
    if (!may_complete) {
      ++counters_.overflow_stopped;
      s = lis_.Stop(&lis_res_);
      break;
    }
    s = lis_.Continue(limits::kMaxLisHypotheses, &lis_res_, left > 0.0 ? std::min(left, kSmallMapStep) : kSmallMapStep);
  }
  Charge(lis_res_.cost);
  view_repeated_ = lis_res_.repeats > 0;
  return s;
}

// The blob tracks' gates: a new blob may continue one that moved at the body's largest rate
// plus its largest speed seen from a beacon gate_depth_m away.
BlobTrackOptions Tracker::BlobTrackOptionsOf(const TrackOptions& o) const {
  BlobTrackOptions b;
  b.max_image_rate_rad_s = o.max_rate_rad_s + o.max_speed_m_s / o.gate_depth_m;
  b.tight_gate_px = o.steady_gate_px;
  b.tight_gate_fraction = o.steady_gate_fraction;
  return b;
}

int Tracker::SteadyBlobs() const { return steady_ == nullptr ? 0 : blob_tracks_.num_steady(); }

// Whether this frame set has more blobs, or more steady ones, than a spread search's own frame
// set had (steady, blobs): perhaps a beacon come into view, which a search of this frame set's
// blobs may confirm at once (restart_cold_search, restart_seeded_search).
bool Tracker::MoreBlobsThan(int steady, int blobs) const { return SteadyBlobs() > steady || num_blobs_ > blobs; }

// Goes on with lis_'s search in progress (ColdSearch, SeededSearch) within what is left of this
// frame set's budget, and charges it.
LisStatus Tracker::ContinueLis() {
  const double before = lis_res_.cost;
  const LisStatus s = lis_.Continue(limits::kMaxLisHypotheses, &lis_res_, std::max(1.0, lis_budget_left_));
  Charge(lis_res_.cost - before);
  return s;
}

// A confirmed fix that a search spread over frame sets found for the frame set at found_t_ns
// seeds this one (within the motion bounds since then): this frame set is tracked again.
TrackStatus Tracker::SeedFromEarlierFix(std::uint64_t found_t_ns, std::uint64_t t_ns, const TrackOptions& o,
                                        TrackResult* r) {
  SetPose(lis_res_.pose, found_t_ns, PositionSigma(lis_res_.solve.covariance), AttitudeSigma(lis_res_.solve.covariance));
  --counters_.frames;  // the same frame set again, now with a seed
  return TrackOnce(blobs_, num_blobs_, t_ns, o, r);
}

// At least one unit per search, so that a frame set's searches always end.
void Tracker::Charge(double cost) { lis_budget_left_ -= std::max(1.0, cost); }

// The cheapest kind of blob triple the steady blobs make (the first of LostInSpace::
// OrderItems' classes): three in one camera prune their beacon triples by two angles, two in
// one camera by one, three in three cameras only by distances (thousands of beacon triples
// more in a 64-beacon map: a whole cold search's work).
Tracker::SteadyShape Tracker::SteadyShapeOf(const BlobObs* blobs, int num_blobs) const {
  if (steady_ == nullptr) return SteadyShape::kNone;
  std::array<int, limits::kMaxCameras> per_camera{};
  int total = 0;
  for (int i = 0; i < num_blobs; ++i)
    if (steady_[static_cast<std::size_t>(i)] != 0) {
      ++per_camera[static_cast<std::size_t>(blobs[i].camera)];
      ++total;
    }
  const int most = *std::max_element(per_camera.begin(), per_camera.end());
  if (total < 3) return SteadyShape::kNone;
  return most >= 3 ? SteadyShape::kOneCamera : most == 2 ? SteadyShape::kTwoCameras : SteadyShape::kThreeCameras;
}

// Lost-in-space with no prior, spread over frame sets (LostInSpace::Begin/Continue): a search
// begun on an earlier frame set goes on with this frame set's budget until it ends or grows
// older than cold_search_s; then one begins on this frame set. *old: the result is of the
// frame set at cold_t_ns_, not this one. Blobs that continue the image tracks of beacons of an
// accepted pose, however old, anchor it as they do a seeded search: with two, a view of three
// beacons gets a complete list within a frame set's budget in a 64-beacon map, where the plain
// search lists none (LostInSpaceTest.AnAnchorCompletesTwoPlusOneColdSearches).
LisStatus Tracker::ColdSearch(const BlobObs* blobs, int num_blobs, std::uint64_t t_ns, const TrackOptions& o,
                              bool* old) {
  *old = false;
  // A search begun before the steady blobs made a triple of a cheaper shape starts over once
  // they do: its own order has that triple nowhere in particular (or behind a dearer one).
  const SteadyShape shape = SteadyShapeOf(blobs, num_blobs);
  const bool steadier = shape < cold_shape_;
  // More blobs, or more steady ones, than its own frame set's, which held too few steady blobs
  // to confirm a pose with one to spare: perhaps a beacon come into view (restart_cold_search).
  const bool in_progress = lis_owner_ == LisOwner::kCold && lis_.searching();
  const bool more = in_progress && o.restart_cold_search && cold_steady_ <= o.lis.confirm_beacons &&
                    MoreBlobsThan(cold_steady_, cold_blobs_);
  counters_.cold_search_restarted += more ? 1U : 0U;
  if (!in_progress || steadier || more || Seconds(t_ns, cold_t_ns_) > o.cold_search_s || t_ns < cold_t_ns_) {
    lis_owner_ = LisOwner::kCold;
    cold_t_ns_ = t_ns;
    cold_shape_ = shape;
    cold_steady_ = SteadyBlobs();
    cold_blobs_ = num_blobs;
    cold_prior_ = LisPrior{};
    AnchorContinuingBlobs(o, &cold_prior_);
    const LisPrior* prior = cold_prior_.num_anchors > 0 ? &cold_prior_ : nullptr;
    LisStatus s = lis_.Begin(blobs, num_blobs, o.lis, &lis_res_, prior, cameras_, steady_);
    if (s == LisStatus::kSearching && prior == nullptr && WantsSteadyList(o))
      s = BeginSteadyList(blobs, num_blobs, o.lis, prior);
    if (s != LisStatus::kSearching) return s;
  }
  *old = cold_t_ns_ != t_ns;
  const LisStatus s = ContinueLis();
  // A search under way keeps the last one's answer until it finds a copy or ends.
  if (s != LisStatus::kSearching || lis_res_.repeats > 0) view_repeated_ = lis_res_.repeats > 0;
  return s;
}

// Lost-in-space near the followed poses (prior), begun on this frame set: as RunLis while it
// ends within the frame set's budget; else it goes on over the next frame sets
// (ContinueSeededSearch) and returns kSearching. Its prior is kept (seeded_prior_): its poses
// are the acquisition's prior copy, which only ChainPrior rewrites, and that runs again only
// once this search has ended or been dropped.
LisStatus Tracker::SeededSearch(const BlobObs* blobs, int num_blobs, const LisPrior& prior, std::uint64_t t_ns,
                                const TrackOptions& o) {
  seeded_prior_ = prior;
  lis_owner_ = LisOwner::kNone;
  LisOptions lo = o.lis;
  lo.max_hypotheses = o.seeded_max_hypotheses;  // (spread, its work is no longer one frame set's time)
  LisStatus s = lis_.Begin(blobs, num_blobs, lo, &lis_res_, &seeded_prior_, cameras_, steady_);
  if (s == LisStatus::kSearching && prior.num_anchors == 0 && WantsSteadyList(o))
    s = BeginSteadyList(blobs, num_blobs, lo, &seeded_prior_);
  if (s == LisStatus::kSearching)
    s = lis_.Continue(limits::kMaxLisHypotheses, &lis_res_, std::max(1.0, lis_budget_left_ - lis_res_.cost));
  Charge(lis_res_.cost);
  if (s != LisStatus::kSearching) {
    view_repeated_ = lis_res_.repeats > 0;
    return s;
  }
  lis_owner_ = LisOwner::kSeeded;
  seeded_t_ns_ = t_ns;
  seeded_steady_ = SteadyBlobs();
  seeded_blobs_ = num_blobs;
  ++counters_.seeded_spread;
  return s;
}

// Goes on with the search near the followed poses begun at seeded_t_ns_ (SeededSearch). True
// when it settles this frame set (*status): still searching, or a confirmed fix of its frame
// set, which seeds this one (as a cold search's does). False: this frame set searches on its
// own, after the chain has followed a complete list of the search's frame set (the next search
// then starts near poses of that time, within bounds of the time since), or when it was
// dropped (older than cold_search_s) or ended with nothing to tell.
bool Tracker::ContinueSeededSearch(std::uint64_t t_ns, const TrackOptions& o, TrackResult* r, TrackStatus* status) {
  lis_owner_ = LisOwner::kNone;
  if (!lis_.searching() || t_ns < seeded_t_ns_ || Seconds(t_ns, seeded_t_ns_) > o.cold_search_s) return false;
  if (o.restart_seeded_search && MoreBlobsThan(seeded_steady_, seeded_blobs_)) {
    ++counters_.seeded_spread_restarted;
    return false;
  }
  const LisStatus s = ContinueLis();
  r->lis_status = s;
  r->acquisition_poses = acquisition_.size();
  if (s == LisStatus::kSearching) {
    lis_owner_ = LisOwner::kSeeded;
    *status = Lost(TrackReason::kAcquiring, r);
    return true;
  }
  ++counters_.seeded_spread_ended;
  view_repeated_ = lis_res_.repeats > 0;
  if (s == LisStatus::kFix && lis_res_.confirmed) {
    *status = SeedFromEarlierFix(seeded_t_ns_, t_ns, o, r);
    return true;
  }
  // (Acquire's pruning by the image tracks and its acceptance need the list's own frame set's
  // blobs: they come with this frame set's search.)
  if ((lis_res_.complete || lis_res_.steady_complete) &&
      (s == LisStatus::kFix || s == LisStatus::kAmbiguous || s == LisStatus::kNoHypothesis)) {
    acquisition_.Follow(lis_res_, seeded_t_ns_);
    if (lis_res_.steady_complete) acquisition_.MarkSteady();  // (kept by this frame set's Acquire)
  }
  return false;
}

TrackStatus Tracker::TrackOnce(const BlobObs* blobs, int num_blobs, std::uint64_t t_ns, const TrackOptions& o,
                               TrackResult* r) {
  ++counters_.frames;
  now_ns_ = t_ns;
  r->t_ns = t_ns;
  r->lis_run = false;
  r->lis_status = LisStatus::kBadInput;
  r->acquisition_poses = 0;
  r->left_out_beacon = -1;
  r->left_out_second = -1;
  r->source = TrackSource::kNone;
  acquired_matches_.num_matches = 0;  // (Acquire sets them for this frame set's Unambiguous)
  if (rig_ == nullptr || !o.IsValid() || num_blobs < 0 || num_blobs > limits::kMaxObservations ||
      (num_blobs > 0 && blobs == nullptr))
    return Lost(TrackReason::kBadInput, r);
  for (int i = 0; i < num_blobs; ++i)
    if (blobs[i].camera < 0 || blobs[i].camera >= rig_->num_cameras || !blobs[i].uv_px.allFinite() ||
        !blobs[i].x_n.allFinite())
      return Lost(TrackReason::kBadInput, r);
  blobs_ = blobs;
  num_blobs_ = num_blobs;
  indexed_blobs_ = matcher_.SetBlobs(blobs, num_blobs, cameras_);

  // 1. Tracking from the last pose: while the gate covers the prediction's error bounds, match
  // nearest blobs; beyond (a long gap, or no velocity yet), the prediction only seeds
  // re-identification (2), which lists every pose consistent with the blobs within the bounds.
  const double since = motion_.known() ? std::max(0.0, Seconds(t_ns, motion_.last_t_ns())) : 0.0;
  if (motion_.known() && since > o.max_seed_s) {
    motion_.Forget();
    has_pose_ = false;
  }
  if (has_pose_ && since > o.max_coast_s) has_pose_ = false;
  if (motion_.known() && TrackPredicted(t_ns, since, o, r)) return r->status;
  return Reidentify(blobs, num_blobs, t_ns, o, r);
}

// 2. Re-identification by lost-in-space: near the followed (or predicted) poses when there are
// any, else a search of its own (in large maps spread over frame sets: ColdSearch).
TrackStatus Tracker::Reidentify(const BlobObs* blobs, int num_blobs, std::uint64_t t_ns, const TrackOptions& o,
                                TrackResult* r) {
  // Not when tracking found two poses near the prediction that explain the blobs equally well
  // (a reflection beside a beacon): lost-in-space would face the same choice, with no motion
  // model to weigh it (seen: confirmed fixes 23 mm off).
  if (ambiguity_refused_) return Lost(TrackReason::kAmbiguous, r);
  if (num_blobs < 3) return Lost(motion_.known() ? TrackReason::kTooFewBeacons : TrackReason::kTooFewBlobs, r);
  r->lis_run = true;
  ++counters_.lis_runs;
  // A search near the followed poses begun on an earlier frame set goes on first.
  if (lis_owner_ == LisOwner::kSeeded) {
    TrackStatus status = TrackStatus::kLost;
    if (ContinueSeededSearch(t_ns, o, r, &status)) return status;
  }
  // While poses are being followed (or a recent pose can seed them), lost-in-space only looks
  // near them: cheaper, and complete far more often when spurious blobs multiply the poses.
  LisPrior prior;
  const bool use_prior = ChainPrior(t_ns, o, &prior);
  if (use_prior) AnchorContinuingBlobs(o, &prior);
  const bool large_map = rig_->num_beacons >= o.lis.fourth_blob_min_beacons;
  if (use_prior && large_map && o.spread_seeded_search) {
    r->lis_status = SeededSearch(blobs, num_blobs, prior, t_ns, o);
    if (r->lis_status == LisStatus::kSearching) {
      r->acquisition_poses = acquisition_.size();
      return Lost(TrackReason::kAcquiring, r);
    }
  } else if (!use_prior && large_map) {
    // Nothing to follow, and a map too large for complete lists of three-beacon poses (the
    // acquisition's chain): the search may span frame sets (ColdSearch).
    bool old = false;
    r->lis_status = ColdSearch(blobs, num_blobs, t_ns, o, &old);
    if (r->lis_status == LisStatus::kSearching) return Lost(TrackReason::kAcquiring, r);
    if (old) {
      // The search ended on an earlier frame set. A confirmed fix seeds this frame set (within
      // the motion bounds since then); a steady list starts the chain at that frame set (the
      // next Acquire keeps its poses on four steady blobs); otherwise start afresh.
      if (r->lis_status == LisStatus::kFix && lis_res_.confirmed) return SeedFromEarlierFix(cold_t_ns_, t_ns, o, r);
      if (lis_res_.steady_complete && lis_res_.num_consistent > 0) {
        acquisition_.Start(lis_res_, cold_t_ns_);
        acquisition_.MarkSteady();
        r->acquisition_poses = acquisition_.size();
      }
      return Lost(TrackReason::kAcquiring, r);
    }
  } else {
    r->lis_status = RunLis(blobs, num_blobs, use_prior ? &prior : nullptr, o);
  }
  return SettleLis(t_ns, use_prior, o, r);
}

// What lost-in-space's outcome (r->lis_status, lis_res_) of a search with or without the prior
// makes of this frame set: a fix that stands on its own, the acquisition's next step, or lost.
TrackStatus Tracker::SettleLis(std::uint64_t t_ns, bool use_prior, const TrackOptions& o, TrackResult* r) {
  bool replaces_prior = false;
  if (use_prior && r->lis_status == LisStatus::kNoHypothesis && lis_res_.complete) {
    // Nothing consistent near the followed (or predicted) poses: fewer than three true beacons
    // in this frame set, or a motion beyond the bounds. A pose lost-in-space settles on its
    // own (typically >= 5 beacons in view) is a fix all the same, and replaces the prior.
    acquisition_.Clear();
    ++counters_.lis_runs;
    if (RunLis(blobs_, num_blobs_, nullptr, o) != LisStatus::kFix ||
        lis_res_.matches.num_beacons < o.lis_fix_min_beacons)
      return Lost(motion_.known() ? TrackReason::kTooFewBeacons : TrackReason::kNoHypothesis, r);
    replaces_prior = true;  // once it is published: a refused fix must not cost the prior
    use_prior = false;
    r->lis_status = LisStatus::kFix;
  }
  // A confirmed fix (>= confirm_beacons beacons, none missing, chance would explain it in
  // fewer than max_false_alarms of the hypotheses tried) stands on its own, prior or not: its
  // search ended early, so its list cannot drive the followed poses (it is not complete).
  if (r->lis_status == LisStatus::kFix && lis_res_.confirmed) use_prior = false;
  // A fix found without a prior stands on its own; under a prior it only says which of the
  // followed poses are left, like any other outcome.
  // Three beacons fit their pose exactly: a unique three-beacon pose may rest on a reflection
  // (seen: one beacon and two reflections in one camera). Lost-in-space alone fixes only with
  // lis_fix_min_beacons; a three-beacon pose is followed like an ambiguous one.
  if (r->lis_status == LisStatus::kFix && !use_prior && lis_res_.matches.num_beacons < o.lis_fix_min_beacons)
    r->lis_status = LisStatus::kAmbiguous;
  if (r->lis_status == LisStatus::kFix && !use_prior) {
    set_ = lis_res_.matches;
    if (!SolveAt(lis_res_.pose, TwinRegion{nullptr, o.twin_m, o.twin_rad}, o, r))
      return Lost(TrackReason::kNoHypothesis, r);
    if (!Unambiguous(o, r)) return Lost(TrackReason::kAmbiguous, r);
    if (!IdentitiesDecided(o, *r)) return Lost(TrackReason::kAmbiguous, r);
    if (!ResidualsFitTheNoise(r->solve, o)) {
      ++counters_.residual_refused;
      const BodyPose refused = r->pose;
      if (!o.leave_one_out || !LeaveOneOut(refused, PoseBounds{o.twin_m, o.twin_rad}, o.hold_gate_px, o, r))
        return Lost(TrackReason::kLargeResidual, r);
    }
    if (replaces_prior) {
      has_pose_ = false;
      motion_.Forget();
    }
    return Publish(TrackSource::kLostInSpace, t_ns, o, r);
  }
  if (r->lis_status == LisStatus::kFix || r->lis_status == LisStatus::kAmbiguous ||
      r->lis_status == LisStatus::kNoHypothesis) {
    if (Acquire(t_ns, o, r)) {
      // (No identity check here: the poses followed to this one were tested by the motion,
      // and three-beacon ones leave each beacon free; measured on four beacons or more: 1-5
      // acquired poses a row refused, no wrong pose fewer.)
      if (!Unambiguous(o, r)) return Lost(TrackReason::kAmbiguous, r);
      return Publish(TrackSource::kAcquired, t_ns, o, r);
    }
    if (!acquisition_.empty()) return Lost(TrackReason::kAcquiring, r);
    if (r->lis_status == LisStatus::kNoHypothesis)
      return Lost(motion_.known() ? TrackReason::kTooFewBeacons : TrackReason::kNoHypothesis, r);
    return Lost(TrackReason::kAmbiguous, r);
  }
  if (r->lis_status == LisStatus::kBudgetExhausted) return Lost(TrackReason::kBudgetExhausted, r);
  if (r->lis_status == LisStatus::kTooFewBlobs) return Lost(TrackReason::kTooFewBlobs, r);
  return Lost(TrackReason::kBadInput, r);
}

}  // namespace mfns::fw
