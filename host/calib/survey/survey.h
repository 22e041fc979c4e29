// The beacon-map self-survey of `mfns-calib survey` (issue 16): every frame set of a recording
// identified and posed by the flyer's own pipeline, then all poses and beacon positions refined
// together (bundle adjustment), with the surveyed map as the prior that also fixes the gauge.
//
// Frames: poses are body poses in the world frame (common/rig/rig.h BodyPose); beacons in the
// world frame. Units: m, rad, px (centroids are distorted image coordinates, as detected).
// Host only: allocates, throws UserError (host/util) on bad input.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <iosfwd>
#include <vector>

#include "common/rig/rig.h"

namespace mfns::host {

// One identified blob: camera `camera` saw beacon `beacon` at centroid uv_px.
struct SurveyObservation {
  int camera = -1;
  int beacon = -1;
  Eigen::Vector2d uv_px = Eigen::Vector2d::Zero();
};

// One frame set the flyer's pipeline posed (a fix): its pose (the start of the adjustment) and
// the identities its solve used.
struct SurveyFrameSet {
  std::uint64_t t_ns = 0;
  BodyPose pose;
  std::vector<SurveyObservation> observations;
  // >= 0: a turntable run's frame set. The frame sets of one group turn about one fixed point
  // (a two-axis turntable's axes meet in it): one point p_b of the body stays at one place p_w
  // of the world, r_w_wb = p_w - C_w_b p_b, so each such pose has its attitude only of its own.
  // -1: a free pose.
  int pivot_group = -1;
};

// What a turntable run's own placement tells (one per pivot group, SurveyFrameSet::pivot_group),
// each part optional. Images see the map's shape and where the run's fixed point and axis sit in
// it, not where the whole map sits in the world: these place it (the survey's own rigid error).
// Frames and units: world w and body b (DESIGN.md), m, rad.
struct TurntablePlacement {
  // The turntable's centre (where its axes meet: the group's fixed point p_w), surveyed in the
  // world; 1-sigma per coordinate (m, > 0). It places the map across the axis; along the axis
  // only with the body's point (below): a run about one axis fixes p_w - C_w_b p_b, not both.
  bool has_centre = false;
  Eigen::Vector3d centre_w = Eigen::Vector3d::Zero();
  double centre_sigma_m = 0.0;
  // The same point in the body frame (the group's p_b): the mount, which defines the body frame
  // in the rig's calibration (docs/calibration.md --mount-mm: p_b = -C_p_b^T r_p_pb); 1-sigma per
  // coordinate (m, > 0). Without it p_b is held only near its start by 1 m.
  bool has_centre_b = false;
  Eigen::Vector3d centre_b = Eigen::Vector3d::Zero();
  double centre_b_sigma_m = 0.0;
  // Its rotation axis in the world (unit; its sign is the one the refined axis keeps), levelled
  // or surveyed, 1-sigma across it (rad, > 0). Holds only for a run that turns about one axis
  // (the main axis, the auxiliary held): every pose of the group then maps one body axis a_b
  // (refined, unit) to one world axis a_w (refined, unit; its prior is this), within
  // SurveyOptions::turntable_wobble_rad.
  bool has_axis = false;
  Eigen::Vector3d axis_w = Eigen::Vector3d::UnitZ();
  double axis_sigma_rad = 0.0;
  // Whether any part is given (a placement with none places nothing).
  bool Any() const { return has_centre || has_centre_b || has_axis; }
  // (Defined here, header only: the placement file's reader and its fuzzer check it without
  // linking the adjustment.)
  bool IsValid(const char** why = nullptr) const;
};

// A usable 1-sigma (m or rad): positive, and its inverse square (the weight it gives) finite.
inline bool UsableSigma(double v) { return v > 0.0 && std::isfinite(v) && std::isnormal(v * v); }

inline bool TurntablePlacement::IsValid(const char** why) const {
  const char* bad = nullptr;
  if (has_centre && (!centre_w.allFinite() || !UsableSigma(centre_sigma_m))) bad = "turntable centre";
  else if (has_centre_b && (!centre_b.allFinite() || !UsableSigma(centre_b_sigma_m))) bad = "turntable centre in the body";
  else if (has_axis && (!axis_w.allFinite() || std::abs(axis_w.norm() - 1.0) > 1e-6 || !UsableSigma(axis_sigma_rad)))
    bad = "turntable axis";
  if (why != nullptr) *why = bad;
  return bad == nullptr;
}

struct SurveyOptions {
  double start_sigma_px = 0.15;  // centroid 1-sigma before it is re-estimated from the residuals
  int reweight_passes = 3;       // solve, re-estimate the centroid sigma, solve again
  int relinearise_passes = 4;    // pose deltas folded into their reference pose between solves
  double huber_sigmas = 3.0;     // robust loss: Huber at this many centroid sigmas
  int max_iterations = 50;       // per Ceres solve
  // A beacon whose refined position lies farther from its surveyed one than the two estimates'
  // uncertainty allows (Mahalanobis distance above this, 5 sigma) is reported "moved?".
  double moved_sigmas = 5.0;
  // Also refine each camera's mounting (C_k_b, r_b_bk; intrinsics held): with the rig's
  // calibration sigma (Rig::has_sigma) each camera has it as its prior, which also fixes the
  // body frame; without, camera 0 is held (it defines the body frame) and the others are free.
  bool refine_cameras = false;
  // Per pivot group (index: group; fewer entries than groups: the rest have none): the
  // turntable's surveyed placement. A group's fixed point and axis need its frame sets.
  std::vector<TurntablePlacement> turntables;
  // The turntable's wobble: how far (rad, 1-sigma) each pose's image of the body axis a_b may
  // stray from the world axis a_w (with TurntablePlacement::has_axis). A few arcsec.
  double turntable_wobble_rad = 2.0 / 3600.0 * 3.14159265358979323846 / 180.0;
  int threads = 1;
  // Tests: before each solve and at its solution, every residual's analytic Jacobians are compared with central
  // differences (1e-6 m or rad; a mismatch above 1e-5 of the row's largest entry: UserError
  // naming the block). Not Ceres's checker, whose Ridders differences start from 0.32 m steps.
  bool check_gradients = false;
  bool IsValid(const char** why = nullptr) const;
};

// One beacon after the adjustment. Unseen beacons keep their surveyed position and sigma.
struct SurveyBeacon {
  Eigen::Vector3d surveyed_w = Eigen::Vector3d::Zero();  // the prior (the rig file's map), m
  Eigen::Vector3d refined_w = Eigen::Vector3d::Zero();   // m
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // of refined_w, m^2
  int observations = 0;   // blobs identified as this beacon
  int frame_sets = 0;     // frame sets that saw it
  double rms_px = 0.0;    // residual RMS of its observations after the adjustment
  double shift_sigmas = 0.0;  // Mahalanobis distance of refined from surveyed (moved test)
  bool moved = false;     // shift_sigmas > SurveyOptions::moved_sigmas
  Eigen::Vector3d Sigma() const { return covariance.diagonal().cwiseSqrt(); }
};

// One camera's mounting after the adjustment (SurveyOptions::refine_cameras). The perturbation
// is on the left of the camera's rotation: C_k_b <- Exp(dtheta_k) C_k_b (rad, camera
// frame), r_b_bk <- r_b_bk + dr_b (m, body frame).
struct SurveyCamera {
  Eigen::Matrix3d C_k_b = Eigen::Matrix3d::Identity();  // refined (the given one when held)
  Eigen::Vector3d r_b_bk = Eigen::Vector3d::Zero();     // m
  Eigen::Vector3d rotation_change_rad = Eigen::Vector3d::Zero();  // dtheta_k from the given C_k_b
  Eigen::Vector3d translation_change_m = Eigen::Vector3d::Zero();  // dr_b from the given r_b_bk
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();  // of [dtheta; dr]
  bool refined = false;  // false: held (not refined, or camera 0 as the gauge)
  int observations = 0;
};

// A turntable run's fixed point (SurveyFrameSet::pivot_group), refined with the rest. A run
// about one axis leaves p_b along it free: a weak prior (1 m) then holds it near its start.
struct SurveyPivot {
  Eigen::Vector3d p_b = Eigen::Vector3d::Zero();  // body frame, m
  Eigen::Vector3d p_w = Eigen::Vector3d::Zero();  // world frame, m
  // With TurntablePlacement::has_axis: the refined axis in the body and in the world (unit).
  bool has_axis = false;
  Eigen::Vector3d axis_b = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis_w = Eigen::Vector3d::Zero();
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();  // of [p_b; p_w], m^2
  int frame_sets = 0;
};

struct SurveyResult {
  std::vector<SurveyBeacon> beacons;  // one per rig beacon, in rig order
  std::vector<SurveyPivot> pivots;    // one per pivot group (0, 1, ...)
  std::vector<SurveyCamera> cameras;  // one per rig camera
  std::vector<BodyPose> poses;        // the refined pose of each frame set given
  double sigma_px = 0.0;              // centroid sigma estimated from the residuals
  bool sigma_estimated = true;        // false: too few observations, start_sigma_px kept
  double rms_px = 0.0;                // residual RMS over every observation
  int observations = 0;
  int outliers = 0;                   // observations beyond the Huber threshold at the end
  std::vector<double> camera_rms_px;  // per rig camera: residual RMS of its observations (0: none)
  std::vector<int> camera_observations;
};

// d dtheta / d euler at C (central differences): how a change of the Euler angles of C
// (common/rotation EulerToMatrix) moves it as C <- Exp(dtheta) C. The rig file's sigmas of
// C_k_b are in Euler angles, SurveyCamera's covariance in dtheta.
Eigen::Matrix3d EulerToRotationJacobian(const Eigen::Matrix3d& C);

// Refines every pose and every observed beacon (and, with refine_cameras, each camera's
// mounting). rig: cameras (held unless refine_cameras) and the surveyed map with beacon_sigma
// (> 0: the prior's 1-sigma per coordinate). Throws UserError when the rig has no beacon sigma,
// an observation names a camera or beacon the rig does not have, a camera to refine is never
// seen, or the solver fails. progress (optional): one line per solve.
SurveyResult AdjustMap(const Rig& rig, const std::vector<SurveyFrameSet>& sets, const SurveyOptions& options,
                       std::ostream* progress = nullptr);

}  // namespace mfns::host
