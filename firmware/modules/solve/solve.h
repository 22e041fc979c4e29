// Joint multi-camera pose solve (issue 4 item 6; the paper's Newton iteration on eq. 2).
//
// Given identified blobs (Match: blob -> beacon) of any cameras of the rig and an initial body
// pose, SolvePose minimises the reprojection error of paper eq. 2 + the camera model over all
// cameras at once:
//
//   min over pose  sum_i rho(| uv_i - ProjectBeacon(cam_i, pose, P_w[beacon_i]) |)
//
// by Levenberg-Marquardt (initial_lambda = 0 starts as plain Gauss-Newton) with the analytic
// 2x6 Jacobians of ProjectBeacon, in the PoseDelta parametrisation of common/rig/rig.h
// (delta = [dr_w (m, world); dtheta_b (rad, body)]). Steps:
//   1. robust IRLS-LM (Huber or Cauchy on the 2-D residual norm, scale in px) from `initial`;
//   2. outlier rejection: while the largest residual exceeds outlier_threshold_px, drop that
//      observation and re-solve (at most max_outlier_rounds times);
//   3. plain least squares over the inliers (optional, default on): at Gaussian centroid noise
//      this is the maximum-likelihood estimate and reaches the Cramer-Rao bound;
//   4. covariance = sigma_px^2 * (J^T J)^-1 over the inliers at the solution (the inverse Fisher
//      information of DESIGN.md), with a rank test on the Jacobi-scaled J^T J.
// Stop rules per LM run: accepted step norm < step_tol (m and rad), relative cost decrease <
// cost_tol, or the iteration bound (<= limits::kMaxSolverIterations; a rejected step counts).
//
// Three beacons give 6 equations for 6 unknowns: a pose but no redundancy (no outlier can be
// found, residual 0). Beacons may be split across cameras in any way (2 + 1, 1 + 1 + 1, ...).
//
// No heap, no exceptions, every loop bounded; fixed-size Eigen only (6x6 LDLT).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>

#include "common/limits.h"
#include "common/rig/rig.h"
#include "firmware/modules/solve/observation.h"

namespace mfns::fw {

enum class SolveStatus : unsigned char {
  kOk = 0,
  kTooFewObservations,  // < min_beacons distinct beacons (before or after outlier rejection)
  kNotConverged,        // iteration bound reached before a stop rule held (pose still returned)
  kDiverged,            // the estimate moved more than max_travel_m from `initial`
  kSingular,            // J^T J rank-deficient (e.g. collinear beacons): pose not determined
  kNonFinite,           // NaN/Inf in the inputs or during the iteration
  kBadInput,            // bad options, index out of range, camera mismatch, > kMaxMatches
  kBehindCamera,        // an observed beacon is behind its camera at the initial pose
  kTooManyOutliers,     // residuals above the threshold remain after max_outlier_rounds
};
inline constexpr int kNumSolveStatus = 9;
const char* ToString(SolveStatus s);

enum class RobustLoss : unsigned char {
  kNone = 0,  // rho(s) = s^2 / 2
  kHuber,     // s^2 / 2 for s <= k, k s - k^2 / 2 beyond
  kCauchy,    // k^2 / 2 log(1 + s^2 / k^2)
};
const char* ToString(RobustLoss l);

struct SolveOptions {
  RobustLoss loss = RobustLoss::kHuber;
  double loss_scale_px = 1.0;  // k of the robust loss, px (> 0)
  double sigma_px = 0.3;       // 1-sigma centroid noise per image axis, for the covariance (> 0)
  int max_iterations = limits::kMaxSolverIterations;  // per LM run, 1..kMaxSolverIterations
  double step_tol = 1e-10;     // stop when an accepted step |delta| < this (m and rad)
  double cost_tol = 1e-12;     // stop when an accepted step lowers the cost by < this fraction
  double initial_lambda = 1e-6;  // LM damping, relative to diag(J^T J); 0: start Gauss-Newton
  double outlier_threshold_px = 3.0;  // residual norm above this: outlier (<= 0: no rejection)
  int max_outlier_rounds = limits::kMaxOutlierRounds;  // 0..kMaxOutlierRounds
  bool final_least_squares = true;  // re-solve the inliers without the robust loss
  int min_beacons = 3;         // distinct beacons needed (>= 3)
  double max_travel_m = 5.0;   // farther from `initial` than this: kDiverged
  double min_rcond = 1e-12;    // smallest eigenvalue ratio of the Jacobi-scaled J^T J
  // Image error per metre of beacon position error (px/m: a focal length over a range; 0: every
  // observation weighs the same). With rig.has_beacon_sigmas each observation of beacon b is
  // weighted by BeaconWeights: its own map error beside the centroid noise, relative to the
  // map's largest (rig.beacon_sigma). So sigma_px^2 (J^T W J)^-1 keeps the meaning of the
  // unweighted covariance (centroid noise, to be scaled by 1 + (k beacon_sigma / sigma_px)^2
  // for the whole 1-sigma), while a beacon surveyed better counts more, and one whose sigma
  // the navigator inflated (beacon health: moved, or a reflection in its place) counts less.
  // The residual statistics (rms_px, max_residual_px, cost) and the outlier test are then of
  // the weighted residuals sqrt(w) |r|: each residual against its own beacon's noise, in the
  // units of the map's largest (so 2 cost / (sigma_px^2 + (k beacon_sigma)^2) is a chi-square).
  double beacon_px_per_m = 0.0;

  // True when every field is usable; otherwise *why (optional) names the first bad field in a
  // static string.
  bool IsValid(const char** why = nullptr) const;
};

struct SolveResult {
  SolveStatus status = SolveStatus::kBadInput;
  BodyPose pose;  // the estimate (meaningful for kOk and kNotConverged)
  // Covariance of the pose in the PoseDelta parametrisation (m^2, rad^2; [dr_w; dtheta_b]):
  // sigma_px^2 (J^T J)^-1 over the inliers. Valid when has_covariance.
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
  bool has_covariance = false;
  double rcond = 0.0;       // of the Jacobi-scaled J^T J (1: perfectly conditioned)
  int iterations = 0;       // LM iterations over every run (accepted + rejected steps)
  int outlier_rounds = 0;   // observations dropped as outliers
  int num_inliers = 0;      // observations (2 equations each)
  int num_beacons = 0;      // distinct beacons among the inliers
  std::array<int, limits::kMaxCameras> inliers_per_camera{};
  // Of the residuals r (2-D) weighted by sqrt(w) (SolveOptions::beacon_px_per_m; w = 1 without
  // per-beacon weights):
  double rms_px = 0.0;           // sqrt(mean w |r|^2) over the inliers
  double max_residual_px = 0.0;  // largest inlier sqrt(w) |r|
  double cost = 0.0;             // final 0.5 * sum w |r|^2 over the inliers, px^2
  // Per match (same order as the input): residual norm at the final pose (-1: not
  // projectable) and whether it is an inlier.
  std::array<double, limits::kMaxMatches> residual_px{};
  std::array<bool, limits::kMaxMatches> inlier{};
};

// Solves for the body pose. `blobs` (num_blobs) is the frame set's blob list and `matches`
// (num_matches <= limits::kMaxMatches) the identified ones; every match must name a blob of
// that list, its camera (< rig.num_cameras, == the blob's camera) and a beacon of the rig.
// A beacon may appear once per camera. Returns result->status. Never allocates.
SolveStatus SolvePose(const Rig& rig, const BlobObs* blobs, int num_blobs, const Match* matches,
                      int num_matches, const BodyPose& initial, const SolveOptions& options,
                      SolveResult* result);

// The weights of the observations `matches` under options.beacon_px_per_m = k (solve.h):
// w = (sigma_px^2 + (k rig.beacon_sigma)^2) / (sigma_px^2 + (k rig.beacon_sigmas[b])^2), 1 for
// a beacon at the map's largest sigma. False (weights untouched) without per-beacon sigmas or k.
bool BeaconWeights(const Rig& rig, const Match* matches, int num_matches, const SolveOptions& options,
                   std::array<double, limits::kMaxMatches>* weight);

// A counter per failure mode, for health reporting by the caller.
struct SolveCounters {
  std::array<std::uint32_t, kNumSolveStatus> by_status{};
  std::uint32_t outliers_rejected = 0;
  void Record(const SolveResult& r);
};

}  // namespace mfns::fw
