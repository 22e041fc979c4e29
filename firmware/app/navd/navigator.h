// mfns-navd's navigation step: blobs of a frame set -> identities, pose, covariance, status,
// through the tracker of firmware/modules/identify/tracker.h (tracking with a constant-velocity
// prediction, lost-in-space re-identification, acquisition over frames when lost-in-space is
// ambiguous). This adapter adds what the loop knows and the tracker does not (a camera set
// aside degrades a fix) and maps the result to the published status and reason.
// No heap after Init; bounded work per frame set.
#pragma once

#include <cstdint>

#include "common/rig/infer_facing.h"
#include "common/rig/rig.h"
#include "firmware/modules/health/beacon_health.h"
#include "firmware/modules/identify/map_repeats.h"
#include "firmware/modules/identify/tracker.h"
#include "firmware/modules/publish/pose_message.h"
#include "firmware/modules/solve/observation.h"

namespace mfns::fw {

struct NavigatorOptions {
  TrackOptions track;  // pixel gates sized for kGateReferencePxPerRad (the paper's cameras)
  // Scale the track's pixel gates at every Init by the rig's focal length (PixelGateScale), so
  // that they keep their angular size on other cameras.
  bool scale_gates_to_rig = true;
  // A rig without facing data gets its beacons' facing from the map's geometry (InferFacing:
  // an LED on a wall shines into the module), so that a beacon seen at a grazing angle, which
  // its LED does not light, is neither predicted nor missed. False: every beacon is predicted
  // from every direction (beacons not on walls).
  bool infer_facing = true;
  InferFacingOptions facing;
  // At Init, which beacons lie in a patch the map repeats elsewhere (FindMapRepeats, after the
  // facing is inferred): there a view cannot be told from its copy, and lost-in-space refuses
  // to fix (reason kRepeatedView). Reported (Navigator::map_repeats: mfns-navd warns at start),
  // changes nothing else. False: not checked (an Init ~16 ms faster for 96 beacons).
  bool check_map_repeats = true;
  MapRepeatsOptions map_repeats;
  // Beacon health after every fix (firmware/modules/health): its search radius is scaled with
  // the pixel gates, its centroid noise is the solve's. A beacon it finds inconsistent is
  // down-weighted: its map sigma, in the navigator's rig, becomes what its residuals show
  // (at least its own), so that the solve weighs it by that (SolveOptions::beacon_px_per_m);
  // back to its own when it clears. False: counted and reported, never down-weighted.
  BeaconHealthOptions health;
  bool down_weight_inconsistent = true;
  // An inconsistent beacon is also left out of identification (tracking, lost-in-space:
  // Tracker::SetExcludedBeacons) until it clears: where the beacons are near (the paper sweep:
  // 5 mm is 5-13 px) its blob falls outside the tight gates, and every pose that predicts it
  // would be refused however little it weighs. Beacon health still looks for it (its nearest
  // free blob), so it clears when it is back where the map says.
  bool exclude_inconsistent = true;
  // Beacons a fix must stand on for beacon health to judge the others by it: three fit any pose
  // exactly, so a three-beacon fix on a moved beacon is bent by it and would flag the good
  // beacons it leaves out (seen: the paper sweep with beacon 9 moved 5 mm flagged beacon 4).
  int judge_fix_min_beacons = 4;
  // With the calibration's 1-sigma in the rig (Rig::has_sigma, from the parameter blob), the
  // published covariance adds the pose error it causes (CalibrationCovariance: each camera
  // parameter propagated through the solve at its solution, the parameters independent).
  // The tracker's fix/degraded bounds stay on centroid noise and map error.
  bool fold_calibration_sigma = true;
  bool IsValid(const char** why = nullptr) const {
    if (judge_fix_min_beacons < limits::kMinNavBeacons) {
      if (why != nullptr) *why = "judge_fix_min_beacons";
      return false;
    }
    return track.IsValid(why) && (!infer_facing || facing.IsValid(why)) && health.IsValid(why) &&
           (!check_map_repeats || map_repeats.IsValid(why));
  }
};

// covariance: of the pose, for the image noise sigma_px plus the beacon map's error
// (BeaconMapErrorPx at the gates' depth) as if it were image noise: with a 0.4 mm survey the
// map's ~1.3 px dominates 0.1-0.15 px of centroid noise; plus, when the rig carries the
// calibration's 1-sigma, the pose error that calibration error causes
// (NavigatorOptions::fold_calibration_sigma).
struct NavOutput {
  NavStatus status = NavStatus::kLost;
  NavReason reason = NavReason::kNoFrames;
  BodyPose pose;
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
  int num_beacons = 0;
  std::array<int, limits::kMaxCameras> beacons_per_camera{};
  double rms_px = 0.0;
  TrackSource source = TrackSource::kNone;
  int num_matches = 0;
  std::array<Match, limits::kMaxMatches> matches{};
};

// The published reason of a tracker outcome.
NavReason ToNavReason(TrackReason r);

class Navigator {
 public:
  // Copies rig (with inferred facing, NavigatorOptions::infer_facing). False on bad options or
  // rig; *why names the problem.
  bool Init(const Rig& rig, const NavigatorOptions& options, const char** why = nullptr);
  // One frame set's blobs (sample time t_ns). delivered: the camera set of match.h: bit k set
  // when camera k delivered a frame (the others predict no beacon, so their silence refutes
  // nothing), and the cells where it could not have seen a beacon (BlindCellBits); cameras_down: a
  // camera is set aside (a fix is then reported degraded, reason kCameraDown).
  void Step(const BlobObs* blobs, int num_blobs, std::uint64_t t_ns, std::uint32_t delivered, bool cameras_down,
            NavOutput* out);
  // Starts the track from a known pose (the dock; the pose before a parameter reload) with
  // its 1-sigma errors (m, rad): taken at the next Step, as of that frame set's time, so that
  // its first frame set with >= 3 beacons is a fix without the acquisition (tracker.h SetPose).
  // Init forgets a pending pose.
  void SetInitialPose(const BodyPose& pose, double sigma_m, double sigma_rad, bool verified = true);
  // The pose of the last Step, when it was not lost (fix or degraded).
  // Whether the track of the last pose was verified (TrackOptions::verify_three_beacons).
  bool LastVerified() const { return tracker_.verified(); }
  bool LastPose(BodyPose* pose) const;
  const TrackCounters& counters() const { return tracker_.counters(); }
  // The tracker's outcome of the last Step (diagnostics: lost-in-space status, followed poses).
  const TrackResult& last_track() const { return result_; }
  // The rig in use, and how many beacons got an inferred facing at Init (none when it had some).
  const Rig& rig() const { return rig_; }
  const InferFacingResult& inferred_facing() const { return facing_; }
  // The beacons in patches the map repeats, as of Init (empty when not checked).
  const MapRepeatsResult& map_repeats() const { return repeats_; }
  const BeaconHealth& beacon_health() const { return health_; }

 private:
  NavigatorOptions options_;
  Rig rig_;  // the caller's rig, with inferred facing when it had none (NavigatorOptions)
  InferFacingResult facing_;
  MapRepeatsResult repeats_;
  Tracker tracker_;
  TrackResult result_;
  bool pending_pose_ = false;
  BodyPose initial_pose_;
  double initial_sigma_m_ = 0.0, initial_sigma_rad_ = 0.0;
  bool initial_verified_ = true;
  bool have_last_ = false;
  BodyPose last_pose_;
  double covariance_scale_ = 1.0;  // published covariance / the solve's (map error)
  BeaconHealth health_;
  std::array<double, limits::kMaxBeacons> own_sigma_m_{};  // each beacon's map sigma at Init
  void JudgeBeacons(const BlobObs* blobs, int num_blobs, std::uint32_t delivered, const NavOutput& out);
};

}  // namespace mfns::fw
