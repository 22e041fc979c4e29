#include "firmware/app/navd/navigator.h"

#include "firmware/modules/solve/calibration_covariance.h"

namespace mfns::fw {

namespace {
// Beacons a pose degraded by its residuals must stand on to judge the beacons by it.
constexpr int kJudgeDegradedBeacons = 6;
}  // namespace

NavReason ToNavReason(TrackReason r) {
  switch (r) {
    case TrackReason::kNone: return NavReason::kNone;
    case TrackReason::kFewBeacons: return NavReason::kFewBeacons;
    case TrackReason::kLargeResidual: return NavReason::kLargeResidual;
    case TrackReason::kLargeCovariance: return NavReason::kLargeCovariance;
    case TrackReason::kUnverified: return NavReason::kUnverified;
    case TrackReason::kTooFewBlobs:
    case TrackReason::kTooFewBeacons: return NavReason::kTooFewBeacons;
    case TrackReason::kAcquiring: return NavReason::kAcquiring;
    case TrackReason::kAmbiguous: return NavReason::kAmbiguous;
    case TrackReason::kBudgetExhausted:
    case TrackReason::kNoHypothesis: return NavReason::kNoHypothesis;
    case TrackReason::kRepeatedView: return NavReason::kRepeatedView;
    case TrackReason::kBadInput:
    case TrackReason::kCount: return NavReason::kSolveFailed;
  }
  return NavReason::kSolveFailed;
}

bool Navigator::Init(const Rig& rig, const NavigatorOptions& options, const char** why) {
  if (!options.IsValid(why)) return false;
  if (const RigStatus rs = ValidateRig(rig); rs != RigStatus::kOk) {
    if (why != nullptr) *why = ToString(rs);
    return false;
  }
  if (rig.num_beacons < limits::kMinNavBeacons) {
    if (why != nullptr) *why = "beacons: fewer than 3 in the rig (navigation needs 3)";
    return false;
  }
  rig_ = rig;
  // Every beacon carries its own map sigma from here on (the map's one when the rig has none:
  // the solve's weights are then all 1), so that beacon health can down-weight one.
  if (!rig_.has_beacon_sigmas) rig_.beacon_sigmas.fill(rig_.beacon_sigma);
  rig_.has_beacon_sigmas = true;
  own_sigma_m_ = rig_.beacon_sigmas;
  facing_ = InferFacingResult{};
  if (options.infer_facing && !rig_.has_facing) InferFacing(options.facing, &rig_, &facing_);
  repeats_ = MapRepeatsResult{};
  if (options.check_map_repeats) FindMapRepeats(rig_, options.map_repeats, &repeats_);
  if (!tracker_.Reset(rig_)) {
    if (why != nullptr) *why = "the tracker cannot use this rig";
    return false;
  }
  options_ = options;
  // Blind cells (a saturated half, unwritten rows) excuse missing beacons while a track is
  // followed, not in lost-in-space: there the missing beacons tell a pose from its twins, and
  // excusing them let a twin through (NavLoop test: a truncated frame, then a 36 cm wrong fix
  // confirmed over frames). A re-identification during glare waits for it to pass.
  options_.track.lis.hypothesis_match.skip_blind_cells = false;
  options_.track.lis.refine_match.skip_blind_cells = false;
  pending_pose_ = have_last_ = false;
  if (options_.scale_gates_to_rig) options_.track.ScalePixelGates(PixelGateScale(rig));
  // The gates must allow for the surveyed map's error (rig.beacon_sigma), seen at the range
  // the tracker sizes its gates for; derived from the caller's options at every Init (reload).
  const double map_px = BeaconMapErrorPx(rig, options_.track.gate_depth_m);
  options_.track.AllowForMapError(map_px);
  // The solve's covariance counts centroid noise only (the tracker's bounds want that); the
  // published one adds the map's error as image noise, so that its 1-sigma is honest.
  const double k = options_.track.MapToCentroidRatio();
  covariance_scale_ = 1.0 + k * k;
  // The solves weigh each beacon by its own sigma, seen at the same range.
  const double px_per_m = LargestFocalPx(rig_) / options_.track.gate_depth_m;
  options_.track.solve.beacon_px_per_m = options_.track.lis.solve.beacon_px_per_m = px_per_m;
  options_.health.sigma_px = options_.track.solve.sigma_px;
  if (options_.scale_gates_to_rig) options_.health.search_px *= PixelGateScale(rig_);
  if (!health_.Reset(rig_, options_.health)) {
    if (why != nullptr) *why = "beacon health: bad options";
    return false;
  }
  return true;
}

void Navigator::Step(const BlobObs* blobs, int num_blobs, std::uint64_t t_ns, std::uint32_t delivered,
                     bool cameras_down, NavOutput* out) {
  if (pending_pose_) {
    tracker_.SetPose(initial_pose_, t_ns, initial_sigma_m_, initial_sigma_rad_, initial_verified_);
    pending_pose_ = false;
  }
  const TrackStatus s = tracker_.Track(blobs, num_blobs, t_ns, options_.track, &result_, delivered);
  have_last_ = s != TrackStatus::kLost;
  if (have_last_) last_pose_ = result_.pose;
  out->source = result_.source;
  out->reason = ToNavReason(result_.reason);
  out->num_matches = 0;
  out->num_beacons = 0;
  out->beacons_per_camera.fill(0);
  out->rms_px = 0.0;
  if (s == TrackStatus::kLost) {
    out->status = NavStatus::kLost;
    return;
  }
  out->status = s == TrackStatus::kFix ? NavStatus::kFix : NavStatus::kDegraded;
  if (out->status == NavStatus::kFix && cameras_down) {
    out->status = NavStatus::kDegraded;
    out->reason = NavReason::kCameraDown;
  }
  const SolveResult& r = result_.solve;
  out->pose = result_.pose;
  out->covariance = r.has_covariance ? Eigen::Matrix<double, 6, 6>(covariance_scale_ * r.covariance)
                                     : Eigen::Matrix<double, 6, 6>::Zero();
  out->num_beacons = r.num_beacons;
  out->beacons_per_camera = r.inliers_per_camera;
  out->rms_px = r.rms_px;
  out->num_matches = result_.matches.num_matches;
  for (int i = 0; i < out->num_matches; ++i)
    out->matches[static_cast<std::size_t>(i)] = result_.matches.matches[static_cast<std::size_t>(i)];
  // Beacons are judged on fixes, on poses degraded by their residuals that stand on enough
  // beacons for one bad beacon to stand out (a moved beacon degrades every pose it is in until
  // it is flagged), and on tracking's poses that left out the one beacon whose removal alone made
  // the others fit the noise (TrackOptions::leave_one_out: >= 4 beacons left, residuals tested).
  if ((s == TrackStatus::kFix && r.num_beacons >= options_.judge_fix_min_beacons) || result_.left_out_beacon >= 0 ||
      (result_.reason == TrackReason::kLargeResidual && r.num_beacons >= kJudgeDegradedBeacons))
    JudgeBeacons(blobs, num_blobs, delivered, *out);
  // The calibration's part after the judging: a miscalibrated camera shifts the pose, which
  // absorbs most of it, so the residuals are judged against the pose's own noise as before.
  Eigen::Matrix<double, 6, 6> calibration;
  if (options_.fold_calibration_sigma && rig_.has_sigma && r.has_covariance &&
      CalibrationCovariance(rig_, blobs, num_blobs, out->matches.data(), out->num_matches, out->pose, options_.track.solve,
                            &calibration))
    out->covariance += calibration;
}

// Beacon health on a fix, and the weights of the beacons whose state changed.
void Navigator::JudgeBeacons(const BlobObs* blobs, int num_blobs, std::uint32_t delivered, const NavOutput& out) {
  const std::uint32_t cameras = delivered & ((std::uint32_t{1} << limits::kMaxCameras) - 1U);
  if (health_.Update(rig_, out.pose, out.covariance, blobs, num_blobs, out.matches.data(), out.num_matches, cameras) == 0)
    return;
  BeaconSet inconsistent;
  for (int b = 0; b < rig_.num_beacons; ++b) {
    const auto sb = static_cast<std::size_t>(b);
    if (options_.down_weight_inconsistent) rig_.beacon_sigmas[sb] = std::max(own_sigma_m_[sb], health_.SuggestedSigmaM(b));
    if (health_.stats(b).state == BeaconState::kInconsistent) inconsistent.Set(b);
  }
  if (options_.exclude_inconsistent) tracker_.SetExcludedBeacons(inconsistent);
}

void Navigator::SetInitialPose(const BodyPose& pose, double sigma_m, double sigma_rad, bool verified) {
  initial_pose_ = pose;
  initial_verified_ = verified;
  initial_sigma_m_ = sigma_m;
  initial_sigma_rad_ = sigma_rad;
  pending_pose_ = true;
}

bool Navigator::LastPose(BodyPose* pose) const {
  if (have_last_) *pose = last_pose_;
  return have_last_;
}

}  // namespace mfns::fw
