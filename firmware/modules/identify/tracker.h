// Frame-to-frame beacon identification and pose: tracking with re-identification (issue 4
// items 5 and 6: status fix / degraded / lost with a reason).
//
// Per frame set (blobs of the cameras that delivered, capture time t_ns):
// 1. Tracking, when a recent pose is known: predict the pose at t_ns (constant velocity on
//    position and attitude from the accepted poses of the last velocity_window_s; hold when
//    only one is known; MotionModel, motion_model.h). The prediction's error bounds
//    (MotionModel::Bounds) are the acceleration bounds over the elapsed time (speed bounds
//    without a velocity), plus gate_sigmas of the last pose's 1-sigma and the innovation
//    slack. While the matching gate that covers them stays within max_gate_px: a beacon
//    predicted well inside an image with no blob in its gate refutes the prediction
//    (forgotten); otherwise each beacon is matched to the nearest blob in the gate
//    (one-to-one; a beacon with two blobs in its gate is left out), the pose solved jointly,
//    re-matched with a tight gate. It is accepted with >= 3 beacons, no missing beacon, a
//    small residual, within the bounds (innovation test: with three beacons a wrong match
//    still fits exactly, but jumps) and, with exactly three observations, no other exact
//    solution (P3P root) consistent with the blobs within the bounds. When a reflection beside
//    a beacon gives trials that disagree, the motion decides if it can: the trial near the
//    constant-velocity Kalman filter's prediction (pose_filter.h; squared Mahalanobis distance
//    within ambiguity_accept_m2, every other trial at ambiguity_reject_m2 or more) is published
//    degraded (not followed: the track coasts).
// 2. Otherwise re-identification by lost-in-space (lost_in_space.h). Without a prior, a fix
//    with >= lis_fix_min_beacons beacons is accepted. When it lists several consistent poses
//    (complete list), they are followed over the next frame sets through motion bounds: a
//    followed pose moves on to the consistent poses within its bounds, or is dropped. The
//    true pose survives every frame set with three true beacons in view; a wrong one dies as
//    soon as the motion brings a beacon into view where it predicts none. The one pose left
//    is accepted (source kAcquired) when it also explains the previous frame set (carried
//    back by the velocity) and has lasted min_acquire_frames frame sets; unseeded, it must
//    also score best among all consistent poses of the frame set (else the chain restarts).
//    Within max_seed_s of the last accepted pose, the prediction seeds the chain with its
//    bounds (after a gap too long for the gate), so that one frame set settles it, two more
//    when reflections are in view (blobs the pose leaves unexplained) and the pose rests on
//    three beacons (on four or more, its residuals are tested instead). When nothing is
//    consistent near the prediction, a lost-in-space fix on its own still counts. (The
//    followed poses: Acquisition, acquisition.h; the tracker decides when one is accepted.)
// 3. An accepted pose is reported as fix, or degraded (fewer than fix_min_beacons beacons,
//    residual above degraded_rms_px, or 1-sigma position / attitude above their bounds, the
//    1-sigma counting the map's error: map_error_px beside the solve's sigma_px; or a track
//    that has stood on three beacons only since it was found: verify_three_beacons);
//    otherwise the frame is lost with a reason.
//
// Pixel conversions and the expected residuals come from one NoiseModel (noise_model.h): the
// rig's pixels per radian, fixed at Reset, with the centroid noise and map error of the options.
//
// Memory: one object (about 5.3 MB, mostly lost-in-space) holds every buffer; construct it at
// start (static or reserved), Reset() it with the rig, then Track() never allocates.
// (It also keeps the previous frame set's blobs: ~50 kB.)
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>

#include "common/limits.h"
#include "common/rig/rig.h"
#include "common/rotation/rotation.h"
#include "firmware/modules/identify/acquisition.h"
#include "firmware/modules/identify/blob_tracks.h"
#include "firmware/modules/identify/lost_in_space.h"
#include "firmware/modules/identify/match.h"
#include "firmware/modules/identify/motion_model.h"
#include "firmware/modules/identify/noise_model.h"
#include "firmware/modules/solve/observation.h"
#include "firmware/modules/solve/solve.h"

namespace mfns::fw {

enum class TrackStatus : unsigned char { kFix = 0, kDegraded, kLost, kCount };
inline constexpr int kNumTrackStatus = static_cast<int>(TrackStatus::kCount);
const char* ToString(TrackStatus s);

enum class TrackReason : unsigned char {
  kNone = 0,
  // kDegraded:
  kFewBeacons,       // fewer than fix_min_beacons beacons
  kLargeResidual,    // residual RMS above degraded_rms_px or fix_rms_sigmas of the noise
  kLargeCovariance,  // 1-sigma position or attitude above its bound
  kUnverified,       // a track that has stood on three beacons only since it began (verify_three_beacons)
  // kLost:
  kTooFewBlobs,      // fewer than 3 blobs and nothing to track
  kTooFewBeacons,    // tracking matched fewer than 3 beacons and re-identification failed
  kAcquiring,        // several poses explain the blobs; following them over frames
  kAmbiguous,        // several poses explain the blobs and the list is incomplete; also
                     // kDegraded: a reflection beside a beacon leaves poses within
                     // ambiguity_max_spread_m of each other (covariance grown to cover them)
  kBudgetExhausted,  // lost-in-space ran out of hypotheses
  kNoHypothesis,     // no pose explains the blobs
  kRepeatedView,     // lost-in-space refused a pose because the map repeats its beacons elsewhere
                     // (LisResult::repeats, map_repeats.h): ambiguous until the view holds more
  kBadInput,         // invalid options, rig not set, bad blob list
  kCount,
};
inline constexpr int kNumTrackReason = static_cast<int>(TrackReason::kCount);
const char* ToString(TrackReason r);

enum class TrackSource : unsigned char {
  kNone = 0,     // no pose this frame
  kTracked,      // predicted from the last poses, matched, solved
  kLostInSpace,  // a lost-in-space fix
  kAcquired,     // the one pose left of a lost-in-space ambiguity followed over frames
  kCount,
};
inline constexpr int kNumTrackSource = static_cast<int>(TrackSource::kCount);
const char* ToString(TrackSource s);

struct TrackOptions {
  LisOptions lis;
  double gate_px = 10.0;             // tracking gate with a velocity prediction
  double hold_gate_px = 60.0;        // tracking gate when only one pose is known
  double max_gate_px = 120.0;
  // The last pose's error in the gate: projected into the images through its covariance when
  // it was a fix on four beacons or more within velocity_window_s (false: always as a position
  // error seen at gate_depth_m plus an attitude error; Tracker::PredictionGatePx).
  bool projected_gate = true;
  double gate_sigmas = 3.0;          // plus this many 1-sigma errors of the last pose, in px:
  double gate_depth_m = 0.5;         // (position errors seen at this beacon range)
  double velocity_window_s = 0.2;    // velocity from the poses of this last span
  double refine_gate_px = 4.0;       // re-matching at the solved pose
  double miss_margin_px = 15.0;      // "well inside the image" for missing beacons
  int max_missing = 0;               // more: the tracked pose is refuted
  double max_rms_px = 2.0;           // more: the tracked pose is refuted
  // A beacon with two blobs in its tracking gate (a reflection beside it) is tried with either
  // blob: up to this many such beacons (2^n solves; the rest are left out, 0..limits::
  // kMaxAmbiguousMatches). The tracked pose is the best of the consistent trials, accepted only
  // when every other consistent trial agrees with it within gate_sigmas of its 1-sigma.
  int max_ambiguous_tried = 4;
  // A trial with as many beacons whose chi-square exceeds the best's by more than this (25:
  // five sigmas) explains the blobs worse and does not count against it.
  double ambiguity_chi2 = 25.0;
  // A trial refused by the innovation test by less than this factor (its distance from the
  // prediction over the allowed one) still competes: the truth itself may lie just beyond the
  // motion bounds (seen after a 1 s coast: the truth 1.2 times out, a reflection's pose inside).
  double ambiguity_innovation_factor = 3.0;
  // When the trials disagree but every one that explains the blobs as well lies within these of
  // the best (a reflection a few pixels beside a beacon moves the pose by millimetres), the best
  // is published degraded (reason kAmbiguous) with the spread added to its covariance, rather
  // than nothing; not fed to the motion model. Errors of a few centimetres and a degree, carried
  // by the covariance, still let a flyer hold its course in a module metres across until the
  // reflection parts from the beacon (typical: three beacons in three cameras, each with a
  // reflection 10-30 px away, trials 15 mm and 1 deg apart). 0: never. Measured (docs/
  // acquisition.md, session 35): 0.01 m / 0.005 rad -> 0.03 / 0.0175, 64-beacon box posed after
  // the first fix 96.9 -> 97.6 %, every published ambiguous pose within 1.7 of its 1-sigma.
  double ambiguity_max_spread_m = 0.03;
  double ambiguity_max_spread_rad = 0.0175;
  // Beyond that spread, the motion decides when it can: each trial's squared Mahalanobis
  // distance from the constant-velocity filter's prediction (MotionModel::filter(), its
  // covariance plus the trial's own). The nearest trial is published degraded (reason
  // kAmbiguous; not followed: the track coasts) when its distance is at most ambiguity_accept_m2 and every trial
  // that is not the same pose lies at ambiguity_reject_m2 or more. The filter's process noise
  // takes the acceleration bounds as 1-sigma over a second, so it is wide: on the acquisition
  // matrix the truth's distance stayed under 4 in 99.9 % of the tracked frame sets (chi-square
  // with 6 degrees of freedom would put its median at 5.3), and a reflection's trial lay at tens
  // to hundreds. 0: never decided by the motion.
  double ambiguity_accept_m2 = 4.0;
  double ambiguity_reject_m2 = 16.0;
  double max_coast_s = 2.0;          // tracking goes on this long without an accepted frame
  double max_seed_s = 5.0;           // and the last pose seeds re-acquisition this long
  // Degraded when:
  int fix_min_beacons = 3;
  double degraded_rms_px = 1.0;
  // ... or residual RMS above this many of the expected per-axis noise (hypot(solve.sigma_px,
  // map_error_px)): the residuals are then not the noise the covariance assumes (seen: a
  // reflection taken for a sixth beacon, 0.42 px RMS at 0.15 px noise, the pose 36 mm off with
  // a 1 mm 1-sigma).
  double fix_rms_sigmas = 2.5;
  double max_position_sigma_m = 0.05;
  // A fix's attitude is within 1 deg of the truth at 4 of its published 1-sigma (0.25 deg).
  // Above it the pose is degraded: the pose error grows with the 1-sigma, and near the P3P's
  // degenerate configurations the pose is off by about its 1-sigma already (seen: a
  // one-camera three-beacon pose with a 1.07 deg 1-sigma, 3.4 deg off, published as fix at
  // the former 0.02 rad). The fixes of the acquisition matrix and of the paper sweep carry
  // at most 0.21 deg (a few dozen of 31 000 above 0.2 deg).
  double max_attitude_sigma_rad = DegToRad(0.25);
  // Motion bounds. Speed and rate bound a held pose and the acquisition between frame sets;
  // the accelerations bound the error of a constant-velocity prediction (0.5 a t^2), which
  // decides how long a gap with 0-2 beacons tracking and the seeded re-identification bridge
  // (a free-flyer in a station accelerates at a few cm/s^2 and turns up to ~10 deg/s^2; a
  // turntable turns at a constant rate). Larger values: more poses fit the wider bounds after
  // a gap, and the first frame sets after it may stay "acquiring".
  double max_speed_m_s = 0.5;
  double max_rate_rad_s = 1.0;
  double max_accel_m_s2 = 0.1;
  double max_angular_accel_rad_s2 = 0.2;
  double chain_slack_m = 0.02;       // plus estimation noise
  double chain_slack_rad = 0.02;
  int min_acquire_frames = 3;        // frame sets an unseeded acquisition must last (>= 2)
  // In maps of >= lis.fourth_blob_min_beacons beacons (smaller maps search each frame set
  // completely, as their acquisition needs): the CPU cost (LisResult::cost: one unit per
  // same-camera P3P hypothesis, ~0.6 us on the host, and the scoring by map size and blob
  // count) of every lost-in-space search of one frame set together: ~10 ms, so that the
  // host's frame set stays under 15 ms and the 53.8 ms deadline of 18.6 Hz holds on a board a
  // few times slower. A cut search is never a guess (kBudgetExhausted).
  int lis_budget_per_frame = 8000;
  // With nothing to follow in a map of >= lis.fourth_blob_min_beacons beacons, one
  // lost-in-space search goes on over the frame sets of this span (each with its budget)
  // before it starts again on a newer one; a confirmed fix of the older frame set then seeds
  // the current one. (Smaller maps search each frame set on its own: the acquisition follows
  // their complete lists of poses over frame sets.)
  double cold_search_s = 0.6;
  // Such a search starts over on a frame set with more blobs, or more steady ones, than its own
  // while its own held at most lis.confirm_beacons steady blobs: in so sparse a view a beacon
  // come into view (its blob new, then steady) is what a confirmation lacks, and a search of the
  // newer blobs may confirm within a budget. A denser view's search goes on: at a cold start
  // its blobs turn steady one by one, and restarting on each lost its work (256-beacon boxes:
  // first fixes 1-7 frame sets later; docs/acquisition.md, session 40).
  bool restart_cold_search = true;
  // In such maps, a search near the followed (or predicted) poses that the frame set's budget
  // cuts goes on over the next frame sets too (within cold_search_s), its list of the frame set
  // it began on: the chain is followed to that frame set, and this one's search starts near
  // it. (False: each frame set searches afresh within its budget; after a gap the prediction's
  // bounds hold more beacon triples than one budget tries, and every search was cut: seen,
  // 34 frame sets in a row in a 64-beacon box; docs/acquisition.md, session 39.)
  bool spread_seeded_search = true;
  // With spread_seeded_search: such a search starts over on the current frame set when it has
  // more blobs, or more steady ones, than the search's own (a beacon come into view: a view of
  // five beacons is confirmed within a budget, where the older blobs cannot be; seen: a random
  // 64-beacon box, 11 frame sets later than by a search of each frame set).
  bool restart_seeded_search = true;
  // With spread_seeded_search: the work units (LisResult::work) such a search may spend in all,
  // 1..limits::kMaxLisHypotheses (lis.max_hypotheses for the others). Spread, its work costs no
  // frame set more time; with 20 000 the searches after gaps among static reflections ended
  // at that cap, incomplete (box 64, 25 reflections, seeds 1-12: 35 000 gives 4 runs +4 to +118
  // fixes, one -6; 60 000 more wrong degraded poses, 9 -> 14; docs/acquisition.md, session 39).
  int seeded_max_hypotheses = 35000;
  // Lost-in-space searches the triples of steady blobs first (blob_tracks.h): blobs that
  // continued a blob of the previous frame sets with a constant image velocity. The image
  // gates come from the motion bounds above and these (false: every blob alike, as before).
  bool steady_blobs_first = true;
  // With steady_blobs_first, in maps of >= lis.fourth_blob_min_beacons beacons: a cold search, or
  // one near a single followed (or predicted) pose, that cannot list every pose within its work
  // units (LostInSpace::MayComplete) lists instead every pose that explains four steady blobs
  // (LisOptions::steady_list), when at least four blobs are steady and that list fits: in a view
  // of four or five beacons, where nothing confirms a pose in one frame set, the list of every
  // pose was out of reach (a 64-beacon map: 241 920 beacon triples for a triple over three
  // cameras) and nothing was followed. The acquisition follows such a list as a complete one,
  // but each followed pose must go on explaining four steady blobs with residuals that fit the
  // noise (Tracker::OnFourSteadyBlobs: a wrong pose fits four blobs only roughly, and the motion
  // moves it off them), and the one left is accepted after min_acquire_frames frame sets
  // (docs/acquisition.md, session 43).
  bool steady_lists = true;
  double steady_gate_px = 3.0;        // BlobTrackOptions::tight_gate_px
  double steady_gate_fraction = 0.2;  // BlobTrackOptions::tight_gate_fraction
  // With steady_blobs_first: a beacon with two blobs in its tracking gate takes the one that
  // continues the steady image track of its last accepted blob when the other blob is new (a
  // track of one frame set: a flickering reflection, a glint), instead of trying both
  // (Tracker::ContinueTracks). Both steady (a reflection that moves with the scene): tried.
  bool continue_blob_tracks = true;
  // With continue_blob_tracks: lost-in-space near a recent pose (the acquisition's seeded and
  // followed poses) searches only the poses that name each continuing blob its beacon
  // (LisPrior::anchors; Tracker::AnchorContinuingBlobs).
  bool anchor_blob_tracks = true;
  // A lost-in-space fix standing on its own (no prior, no chain) and an acquired pose must fit
  // the noise: the chi-square of its residuals (over the expected residual variance: centroid
  // noise and the map's error) within this one-sided normal quantile (3.72: p = 1e-4) for its
  // degrees of freedom (Tracker::ResidualsFitTheNoise). 0: not tested.
  double residual_test_sigmas = 3.72;
  // A track that began on exactly three beacons (an acquisition or a re-acquisition: three
  // beacons fit their pose exactly) is published degraded, reason kUnverified, until one of its
  // poses rests on four beacons or more whose residuals fit the noise (ResidualsFitTheNoise). An
  // unmapped steady light (a reflection that moves with the scene, a lamp, an indicator LED)
  // with two beacons, or two with one, fits a wrong pose exactly, and the motion does not refute
  // it (docs/acquisition.md, session 28: 29 wrong fixes 0.18-0.75 m and 8-38 deg off in
  // 64-128-beacon stations with 25 unmapped points; 220, up to 4 m off, in 12-24-beacon ones).
  // A track that goes on keeps its verification (tracked, or re-identified within
  // velocity_window_s of its last pose or near a pose given by SetPose, which is verified).
  // false: three beacons make a fix, as before; only where every steady light the cameras can
  // see is a mapped beacon (a dark lab like the paper's).
  bool verify_three_beacons = true;
  // A pose on exactly three beacons whose blobs are not all steady (one image track younger than
  // BlobTracks' steady_age frame sets) is published degraded, reason kUnverified, also on a
  // verified track, when it follows a gap (the frame set before carried no pose) or leaves a
  // steady blob unexplained (a tracked beacon's blob dropped for a new one). Three beacons fit
  // any pose exactly, so the motion's bounds alone check a blob that just appeared where a beacon
  // is predicted: the beacon back in view, or a reflection beside where it would be. Seen with
  // random beacon layouts and jitter 0.5 (docs/acquisition.md, session 33): fixes 21-38 mm and
  // 1.1-1.6 deg off, within the innovation bounds. Without either condition it also degraded the
  // first frame sets after a given pose and every beacon entering a three-beacon view.
  // Needs steady_blobs_first (no blob tracks: no test).
  bool three_beacon_fix_steady = true;
  // A seeded chain (a re-acquisition after a gap) in which exactly one followed pose rests on
  // steady blobs only, with three beacons or more, while every other names a blob that is new
  // (a reflection flickering beside a beacon) and explains no more beacons than it, keeps that
  // one (Tracker::PruneToSteady; a pose explaining more has a beacon just come into view). Not
  // sound as a fix: an unmapped steady light with two beacons fits such a pose too, when the
  // truth (two beacons) is in no list (docs/acquisition.md, sessions 28-29); the track it starts
  // is a new one, so on three beacons it is published unverified (verify_three_beacons).
  bool prune_to_steady = true;
  // A track whose prediction gate exceeds max_gate_px within velocity_window_s of its last pose
  // (a pose on three beacons: weak geometry, a 1-sigma of centimetres, so a gate of hundreds of
  // pixels) goes on from the blobs that continue the steady image tracks of its beacons
  // (Tracker::TrackContinuing): three or more such blobs carry their identities from the image
  // alone, where the wide gate would send the frame set to re-identification (seeded, then
  // waiting two frame sets with reflections in view: two frame sets of three lost, over and over,
  // in three-beacon stretches). The solve passes tracking's tests (tight re-match, no missing
  // beacon, no P3P twin within the bounds, the innovation test) and, three beacons fitting
  // exactly, the motion filter's: its squared Mahalanobis distance from the filter's prediction
  // (as DecideByMotion) at most continuity_max_m2; and only on a verified track
  // (verify_three_beacons: an unverified one may be an unmapped light's alias). 0: off.
  double continuity_max_m2 = 16.0;
  // A stand-alone lost-in-space fix must decide its identities itself (IdentitiesDecisive,
  // identities.h): no matched beacon may have another free blob of its camera within this
  // squared Mahalanobis distance of its leave-one-out prediction (13.8: 99.9 % of two degrees of
  // freedom). Else the frame set is lost (kAmbiguous) and the search goes on. 0: off.
  double identity_gate_chi2 = 13.8;
  // When tracking's solve on every matched beacon is refused (a beacon missing from the tight
  // gate, residuals beyond the noise) and the prediction matched four beacons or more with one
  // blob each, each beacon is left out in turn (Tracker::LeaveOneOut): when exactly one
  // leave-out fits the blobs and the prediction (ResidualsFitTheNoise, the innovation test),
  // that pose is published degraded (kLargeResidual) with TrackResult::left_out_beacon, and the
  // track goes on. A beacon moved after the survey (5-13 px off at the paper sweep's range)
  // would otherwise lose every pose it is in; the navigator judges beacon health on these poses.
  bool leave_one_out = true;
  // Beacons the refused solve must stand on (>= 5): each leave-out then keeps four, whose
  // residuals test it. With four, every leave-out fits its three exactly and only the
  // prediction could choose, but a track that reached them through three-beacon poses on the
  // moved beacon predicts its bias: the leave-out of a good beacon would be chosen (measured on
  // the paper sweep, docs/navd.md).
  int leave_one_out_min_beacons = 5;
  // ... and at most this many: one tracking per beacon (with its trials) bounds the cost. Not
  // fewer: a moved beacon whose blob falls outside the tight gate is "missing" and refuses every
  // pose of a view of 9-11 beacons too (box 128 seed 3: never flagged with 8, 66 fixes of 249;
  // flagged after 8 frame sets in view with 32, 242 fixes).
  int leave_one_out_max_beacons = 32;
  // When no single leave-out fits: each pair of the beacons left out instead, on poses of
  // leave_two_out_min_beacons to leave_two_out_max_beacons beacons (C(n, 2) trackings: at most 66;
  // 0: never). Each leave-out keeps four beacons or more, whose residuals test it. Two beacons
  // moved together (measured: a 6-beacon view with two of them 5-7 px off refused every pose from
  // the first frame set on, and beacon health never judged either; docs/navd.md, "Two moved
  // beacons").
  int leave_two_out_min_beacons = 6;
  int leave_two_out_max_beacons = 12;
  int lis_fix_min_beacons = 4;       // a lost-in-space fix on its own needs this many beacons
                                     // (three fit exactly, so a reflection among them shows not)
  double chain_stale_s = 1.0;        // a followed pose unconfirmed this long restarts it all
  // A three-beacon pose from lost-in-space or an unseeded acquisition is refused when another
  // exact solution (another P3P root) consistent with the blobs lies this near; when tracking,
  // the prediction's bounds take this place (a root outside them is refuted by the motion).
  double twin_m = 0.2;
  double twin_rad = 0.2;
  // A tracked pose is refused when it lies farther from the prediction than this, plus the
  // acceleration bounds over the elapsed time and gate_sigmas of the last pose's 1-sigma.
  double innovation_m = 0.02;
  double innovation_rad = 0.02;
  // The beacon map's error seen as image noise (px, 1-sigma; set by AllowForMapError). A
  // tracked pose may then also differ from the prediction by gate_sigmas of its own 1-sigma
  // for that noise: when a beacon leaves the view, the pose on the remaining three jumps by the
  // map's error, amplified by their weaker geometry.
  double map_error_px = 0.0;
  SolveOptions solve;

  bool IsValid(const char** why = nullptr) const;
  // The pixel gates and margins above (and lost-in-space's) are sized for the paper's cameras
  // (1280 x 1024, ~1600 px/rad); for other cameras multiply them by the ratio of focal lengths
  // (e.g. 0.25 for the same optics at 320 x 256), so that they keep their angular size.
  // (Residual bounds in px are left: they follow the centroid noise, not the focal length.)
  void ScalePixelGates(double factor);
  // The residual bounds above (max_rms_px, degraded_rms_px, refine_gate_px,
  // solve.outlier_threshold_px, and lost-in-space's max_rms_px, refine_match.gate_px,
  // solve.outlier_threshold_px) are sized for
  // centroid noise (~0.1 px). A surveyed beacon map adds map_px (1-sigma, px; BeaconMapErrorPx)
  // to every residual, and a three-beacon pose passes it on, amplified, to the beacons it
  // predicts: then a true beacon entering the view is dropped as an outlier or found "missing",
  // the track is refuted and re-acquisition takes many frame sets. Each bound b becomes
  // sqrt(b^2 + (k map_px)^2), k = 4 for residual gates and 2 for the RMS bounds (map_px <= 0:
  // unchanged), and map_error_px = map_px. Call once on the options (not cumulative). (The covariance is left at the
  // centroid noise: the prediction's bounds grow with it, and the map's error, the same for
  // frame sets that see the same beacons, does not spread the motion estimate like noise.)
  void AllowForMapError(double map_px);
  // map_error_px / solve.sigma_px (0 without a map error): the solve's covariance is for the
  // centroid noise alone; the map's share of a pose's 1-sigma is this times it.
  double MapToCentroidRatio() const {
    return NoiseModel{}.WithImageNoise(solve.sigma_px, map_error_px).MapToCentroidRatio();
  }
};

// The focal length (px/rad) the pixel gates of TrackOptions are sized for: the paper's cameras.
inline constexpr double kGateReferencePxPerRad = 1600.0;
// The factor for TrackOptions::ScalePixelGates that keeps the gates' angular size on `rig`:
// its largest focal length over kGateReferencePxPerRad (1 when the rig has no camera).
double PixelGateScale(const Rig& rig);

// The image error (px, 1-sigma) that the beacon map's uncertainty (rig.beacon_sigma, m per
// coordinate) causes at range_m with the rig's largest focal length; 0 when it is unknown.
double BeaconMapErrorPx(const Rig& rig, double range_m);

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
  int left_out_beacon = -1;      // the beacon a leave-one-out pose left out (degraded), or -1
  int left_out_second = -1;      // and the second of a leave-two-out, or -1
};

// A counter per outcome, for health reporting.
struct TrackCounters {
  std::uint32_t frames = 0;
  std::array<std::uint32_t, kNumTrackStatus> by_status{};  // indexed by TrackStatus
  std::array<std::uint32_t, kNumTrackReason> by_reason{};  // indexed by TrackReason
  std::uint32_t tracked = 0, lost_in_space_fixes = 0, acquired = 0;
  std::uint32_t ambiguous_tried = 0;    // tracked frame sets with a beacon tried with two blobs
  std::uint32_t ambiguous_refused = 0;  // ... whose consistent trials disagreed: not tracked
  std::uint32_t ambiguous_published = 0;  // ... of which published degraded (within the spread)
  std::uint32_t ambiguous_decided = 0;    // ... of which decided by the motion (ambiguity_accept_m2)
  std::uint32_t lis_runs = 0, track_refuted = 0, innovation_refused = 0;
  std::uint32_t previous_refused = 0;  // an acquired pose that does not explain the previous frame set
  std::uint32_t steady_unexplained = 0;  // an acquired three-beacon pose that leaves a steady blob unexplained
  std::uint32_t chain_restarts = 0;    // an unseeded acquisition's survivor outscored: restarted
  std::uint32_t ambiguity_continued = 0;  // an ambiguous beacon given the blob that continues its track
  std::uint32_t continuity_refuted = 0;   // a followed pose that names a continuing blob another beacon
  std::uint32_t anchored_searches = 0;    // lost-in-space searches (near a pose, or cold) with continuing blobs anchored
  std::uint32_t unsteady_refused = 0;     // an acquired three-beacon pose on a blob that is not steady
  std::uint32_t steady_pruned = 0;        // followed poses on a new blob dropped for the one on steady blobs
  std::uint32_t steady_lists = 0;         // searches that listed the poses on four steady blobs instead (steady_lists)
  std::uint32_t steady_refuted = 0;       // poses of a steady chain dropped: not on four steady blobs that fit the noise
  std::uint32_t residual_refused = 0;     // a stand-alone LIS fix or acquired pose: residuals beyond the noise
  std::uint32_t identity_refused = 0;     // a stand-alone LIS fix with a rival blob for a beacon (IdentitiesDecisive)
  std::uint32_t identity_swapped = 0;     // a tracked pose's beacon given a rival blob that explains the blobs better
  std::uint32_t left_out = 0;             // tracked poses published with one beacon left out (LeaveOneOut)
  std::uint32_t left_out_undecided = 0;   // ... refused: no leave-out, or several, fit
  std::uint32_t left_out_budget_out = 0;  // ... refused: the frame set's budget ran out first
  std::uint32_t left_two_out = 0;         // ... of the published, two beacons left out
  std::uint32_t seeded_spread = 0;        // searches near followed poses that went on over frame sets
  std::uint32_t seeded_spread_ended = 0;  // ... and ended there (their list followed to their frame set)
  std::uint32_t seeded_spread_restarted = 0;  // ... dropped for the current frame set's blobs (restart_seeded_search)
  std::uint32_t cold_search_restarted = 0;    // a cold search in progress started over for more blobs (restart_cold_search)
  std::uint32_t overflow_stopped = 0;     // a small map's search stopped at the budget, its list overflowed or too long to complete (RunSmallMapLis)
  std::uint32_t continued = 0;            // tracked beyond max_gate_px on continuing blobs (TrackContinuing)
  std::uint32_t continuity_refused = 0;   // ... refused by tracking's tests or the motion filter
  SolveCounters solve;
};
static_assert(std::tuple_size_v<decltype(TrackCounters::by_status)> == static_cast<std::size_t>(TrackStatus::kCount),
              "by_status is indexed by TrackStatus");
static_assert(std::tuple_size_v<decltype(TrackCounters::by_reason)> == static_cast<std::size_t>(TrackReason::kCount),
              "by_reason is indexed by TrackReason");

class Tracker {
 public:
  // Forgets every pose. The rig must stay alive and unchanged until the next Reset.
  bool Reset(const Rig& rig);

  // Starts tracking from a known pose at t_ns (e.g. the flyer leaves its dock, or the track
  // carried over a parameter reload): no velocity yet, so the next frame set is matched with
  // hold_gate_px, and the pose's 1-sigma errors (m, rad; 0: exact) widen the prediction's
  // bounds by gate_sigmas of them. While the gate covering them exceeds max_gate_px, the pose
  // seeds lost-in-space instead (only poses within the bounds are sought): a three-beacon
  // frame set is then settled at once, without the acquisition's motion.
  // verified: the pose is known to be right (a dock, a confirmed fix); false for a pose carried
  // over from a track that was not (TrackOptions::verify_three_beacons). A track that the pose
  // seeds, by tracking or by re-identification near it, keeps that.
  void SetPose(const BodyPose& pose, std::uint64_t t_ns, double sigma_m = 0.0, double sigma_rad = 0.0,
               bool verified = true);
  // Whether the track has been verified (TrackOptions::verify_three_beacons).
  bool verified() const { return verified_; }

  // Identifies and solves one frame set; t_ns is its capture time (monotonic, ns). cameras: bit k
  // set when camera k delivered a frame in this frame set (a camera set aside or timed out
  // predicts no beacon, so it refutes nothing).
  TrackStatus Track(const BlobObs* blobs, int num_blobs, std::uint64_t t_ns, const TrackOptions& options,
                    TrackResult* result, std::uint32_t cameras = kAllCameras);

  const TrackCounters& counters() const { return counters_; }

  // Beacons left out of matching, in tracking and in lost-in-space, until the next call (none
  // after Reset): Navigator passes beacon health's inconsistent beacons (a beacon moved after
  // the survey: its blob would fall outside the tight gates and refuse every pose it is in).
  void SetExcludedBeacons(const BeaconSet& beacons);

 private:
  // Where a second exact three-beacon solution would be indistinguishable from the solution:
  // within max_m / max_rad of *centre (nullptr: of the solution itself).
  struct TwinRegion {
    const BodyPose* centre = nullptr;
    double max_m = 0.0;
    double max_rad = 0.0;
  };
  // One consistent (or nearly consistent) trial of tracking's ambiguous beacons.
  struct Trial {
    BodyPose pose;
    int beacons = 0;    // beacons its solve used
    double cost = 0.0;  // its solve's cost: 0.5 * sum of squared inlier residuals, px^2
    std::uint32_t choice = 0;  // which blob each ambiguous beacon took (ChooseAmbiguous)
    Matrix6d cov = Matrix6d::Zero();  // its solve's covariance for the centroid noise
  };
  // Tracking (tracker.cc): from the motion model's prediction, with its ambiguity trials.
  bool TrackPredicted(std::uint64_t t_ns, double since_s, const TrackOptions& o, TrackResult* r);
  bool TrackFrom(const BodyPose& predicted, const PoseBounds& bounds, double gate_px, const TrackOptions& o,
                 TrackResult* r, bool* refuted);
  bool SolveTracked(const BodyPose& predicted, const PoseBounds& bounds, const TrackOptions& o, TrackResult* r,
                    bool* refuted, double* innovation);
  bool ChooseAmbiguous(std::uint32_t choice, int n);
  bool AgreeWith(const TrackResult& best, int num_trials, const TrackOptions& o);
  bool PublishAmbiguous(const TrackOptions& o, TrackResult* r);
  bool DecideByMotion(const BodyPose& predicted, const PoseBounds& bounds, const TrackOptions& o, TrackResult* r);
  bool TrackContinuing(const BodyPose& predicted, const PoseBounds& bounds, const TrackOptions& o, TrackResult* r);
  bool LeaveOutFits(const BodyPose& predicted, const PoseBounds& bounds, double gate_px, const TrackOptions& o,
                    const BeaconSet& excluded, int a, int b);
  bool LeaveOneOut(const BodyPose& predicted, const PoseBounds& bounds, double gate_px, const TrackOptions& o,
                   TrackResult* r);
  bool Unambiguous(const TrackOptions& o, TrackResult* r);
  bool IdentitiesDecided(const TrackOptions& o, const TrackResult& r);
  void TakeBetterRival(const TrackOptions& o, TrackResult* r);
  void ContinueTracks(const TrackOptions& o);
  void RememberTracks(const MatchSet& matches);
  int ContinuingBlobs(const TrackOptions& o);
  bool KeepsContinuingBlobs(const BodyPose& pose, const TrackOptions& o);
  void AnchorContinuingBlobs(const TrackOptions& o, LisPrior* prior);
  void SameTolerance(const TrackResult& b, const TrackOptions& o, double* tol_m, double* tol_rad) const;
  void SameTolerance(const Matrix6d* cov, const TrackOptions& o, double* tol_m, double* tol_rad) const;
  bool SamePoseWithin(const TrackResult& a, const TrackResult& b, const TrackOptions& o) const;
  bool SolveAt(const BodyPose& start, const TwinRegion& twin, const TrackOptions& o, TrackResult* r);
  bool NearbyTwin(const TwinRegion& region, const TrackOptions& o, const TrackResult* r);
  // Re-identification and the acquisition's decisions.
  TrackStatus Reidentify(const BlobObs* blobs, int num_blobs, std::uint64_t t_ns, const TrackOptions& o,
                         TrackResult* r);
  TrackStatus SettleLis(std::uint64_t t_ns, bool use_prior, const TrackOptions& o, TrackResult* r);
  bool ChainPrior(std::uint64_t t_ns, const TrackOptions& o, LisPrior* prior);
  bool Acquire(std::uint64_t t_ns, const TrackOptions& o, TrackResult* r);
  bool ExplainsPrevious(const BodyPose& pose, std::uint64_t t_ns, const TrackOptions& o, int* unexplained);
  bool SurvivorIsBest(std::uint64_t t_ns, const TrackOptions& o);
  bool LeavesSteadyBlob(const MatchSet& matches) const;
  bool OnSteadyBlobs(const MatchSet& matches) const;
  bool OnNewBlob(const MatchSet& matches) const;
  bool OnFourSteadyBlobs(const BodyPose& pose, const TrackOptions& o);
  void KeepSteadyChain(const LisResult& list, const TrackOptions& o);
  bool WantsSteadyList(const TrackOptions& o);
  LisStatus BeginSteadyList(const BlobObs* blobs, int num_blobs, LisOptions lo, const LisPrior* prior);
  int PruneToSteady(const TrackOptions& o);
  void PredictionGatePx(const BodyPose& predicted, double since_s, const TrackOptions& o, double* gate,
                        double* with_map) const;
  double ImageSigmaPx(const BodyPose& pose, const Matrix6d& cov) const;
  bool ResidualsFitTheNoise(const SolveResult& s, const TrackOptions& o) const;
  bool BeyondFixSigmas(const SolveResult& s, const TrackOptions& o) const;
  void KeepBlobs(std::uint64_t t_ns);
  TrackStatus TrackOnce(const BlobObs* blobs, int num_blobs, std::uint64_t t_ns, const TrackOptions& o,
                        TrackResult* result);
  void Accept(std::uint64_t t_ns, const TrackOptions& o, TrackResult* r);
  TrackStatus Publish(TrackSource source, std::uint64_t t_ns, const TrackOptions& o, TrackResult* r);
  void PublishUnfollowed(TrackResult* r);
  TrackStatus Lost(TrackReason why, TrackResult* r);
  void CountOutcome(const TrackResult& r);  // by status and reason
  // Lost-in-space within the frame set's budget (lis_budget_per_frame).
  LisStatus RunLis(const BlobObs* blobs, int num_blobs, const LisPrior* prior, const TrackOptions& o);
  LisStatus RunSmallMapLis(const BlobObs* blobs, int num_blobs, const LisPrior* prior, const TrackOptions& o);
  void Charge(double cost);
  LisStatus ColdSearch(const BlobObs* blobs, int num_blobs, std::uint64_t t_ns, const TrackOptions& o, bool* old);
  LisStatus SeededSearch(const BlobObs* blobs, int num_blobs, const LisPrior& prior, std::uint64_t t_ns,
                         const TrackOptions& o);
  bool ContinueSeededSearch(std::uint64_t t_ns, const TrackOptions& o, TrackResult* r, TrackStatus* status);
  LisStatus ContinueLis();
  TrackStatus SeedFromEarlierFix(std::uint64_t found_t_ns, std::uint64_t t_ns, const TrackOptions& o, TrackResult* r);
  BlobTrackOptions BlobTrackOptionsOf(const TrackOptions& o) const;

  const Rig* rig_ = nullptr;
  std::uint64_t now_ns_ = 0;  // this frame set's capture time
  // Built at Reset from the rig (px/rad); Track completes it with its options' image noise.
  NoiseModel noise_;
  AcquisitionLimits limits_;  // the motion and acquisition bounds of Track's options
  const BlobObs* blobs_ = nullptr;
  int num_blobs_ = 0;
  int indexed_blobs_ = 0;  // blobs of cameras that delivered
  BeaconMatcher matcher_;
  LostInSpace lis_;
  LisResult lis_res_;
  SolveResult identity_solve_;  // TakeBetterRival's solve with the rival blob
  // The last finished search (or the one under way, once it found one) refused a pose for a
  // copy of its beacons in the map (LisResult::repeats): lost frame sets say kRepeatedView.
  // Cleared by a published pose.
  bool view_repeated_ = false;
  BlobTracks blob_tracks_;  // the blobs' image tracks: steady ones are searched first
  const std::uint8_t* steady_ = nullptr;  // blob_tracks_'s flags for this frame set, or nullptr
  // The blob track id (BlobTracks::id) of each beacon's last accepted blob, by camera and
  // beacon (0: none; an id that no blob carries any more matches nothing).
  std::array<std::uint32_t, limits::kMaxCameras * limits::kMaxBeacons> beacon_track_{};
  std::uint32_t& BeaconTrack(int camera, int beacon) {
    return beacon_track_[static_cast<std::size_t>(camera * limits::kMaxBeacons + beacon)];
  }
  // This frame set's steady blobs that continue a remembered beacon's track (ContinuingBlobs):
  // blob index and beacon.
  struct ContinuingBlob {
    int blob = 0;
    int beacon = 0;
  };
  std::array<ContinuingBlob, limits::kMaxObservations> continuing_{};
  int num_continuing_ = 0;
  static constexpr int kMaxAnchors = 5;
  std::array<LisAnchor, kMaxAnchors> anchors_{};  // continuing blobs as anchors (AnchorContinuingBlobs)
  // Steady blob triples, cheapest first (SteadyShapeOf).
  enum class SteadyShape { kOneCamera, kTwoCameras, kThreeCameras, kNone };
  SteadyShape SteadyShapeOf(const BlobObs* blobs, int num_blobs) const;
  SteadyShape cold_shape_ = SteadyShape::kNone;  // when the cold search in progress began
  LisPrior cold_prior_;  // the cold search's anchors (no poses; AnchorContinuingBlobs)
  double lis_budget_left_ = 0.0;  // LisResult::cost left to this frame set
  std::uint64_t cold_t_ns_ = 0;  // the frame set of the cold search in progress
  int cold_steady_ = 0, cold_blobs_ = 0;  // its frame set's steady blobs, and all its blobs
  // Whose search lis_ has under way over frame sets (lis_.searching()): the cold one, or one
  // near the followed poses (SeededSearch: its prior, whose poses are acquisition_'s prior
  // copy, unchanged until the search ends, and its frame set).
  enum class LisOwner { kNone, kCold, kSeeded };
  LisOwner lis_owner_ = LisOwner::kNone;
  LisPrior seeded_prior_;
  std::uint64_t seeded_t_ns_ = 0;
  int seeded_steady_ = 0, seeded_blobs_ = 0;  // its frame set's steady blobs, and all its blobs
  int SteadyBlobs() const;  // this frame set's (BlobTracks::num_steady; 0 without them)
  bool MoreBlobsThan(int steady, int blobs) const;
  MatchSet set_;
  // Tracking's trials of ambiguous beacons: the unambiguous matches, the ambiguous beacons,
  // the best consistent trial and every consistent trial.
  MatchSet base_;
  AmbiguityList ambiguous_;
  bool ambiguity_refused_ = false;  // this frame set's trials disagreed
  int num_trials_ = 0;              // competitors in trials_ (TrackFrom)
  double ambiguity_spread_m_ = 0.0, ambiguity_spread_rad_ = 0.0;  // by this much (AgreeWith)
  TrackResult trial_, trial_result_;
  TrackResult loo_result_, loo_best_;  // a leave-out's tracking, and the one that fits (LeaveOneOut)
  MatchSet loo_set_;        // the beacons LeaveOneOut leaves out in turn
  static constexpr int kMaxTrials = 1 << limits::kMaxAmbiguousMatches;
  std::array<Trial, kMaxTrials> trials_{};
  P3pRayTriple twin_;
  std::array<BodyPose, limits::kMaxP3pSolutions> twin_poses_{};
  MatchSet twin_set_;
  // The track: tracking may predict from the motion model's last pose (has_pose_); the motion
  // model alone may still seed re-acquisition (MotionModel::known) up to max_seed_s.
  bool has_pose_ = false;
  bool last_fix_ = false;  // the last accepted pose was a fix on >= 4 beacons (PredictionGatePx)
  bool verified_ = false;  // the track has had a pose on >= 4 beacons that fit the noise (Accept)
  bool given_seed_ = false;  // SetPose's pose seeds the track: nothing accepted since
  MotionModel motion_;
  Acquisition acquisition_;  // poses followed while lost-in-space is ambiguous
  // This frame set's acquired pose (its matches; none otherwise): a beacon with two blobs in
  // Unambiguous's gate takes the pose's blob when that is steady and the other new
  // (ContinueTracks).
  MatchSet acquired_matches_;
  // The previous frame set's blobs (ExplainsPrevious); -1: none.
  int prev_num_blobs_ = -1;
  std::uint32_t cameras_ = kAllCameras, prev_cameras_ = kAllCameras;
  std::uint64_t prev_t_ns_ = 0;
  std::array<BlobObs, limits::kMaxObservations> prev_blobs_{};
  TrackCounters counters_;
};

}  // namespace mfns::fw
