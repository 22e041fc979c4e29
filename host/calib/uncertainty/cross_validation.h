// Cross-validation of a rig calibration (issue 18 item 3, as mrcal compares two independent
// calibrations): the images split into two halves, each calibrated alone, and the difference
// of the two rigs set against the difference their covariances predict.
//
// Split: each camera's turntable images alternate between the halves in dataset order (the
// first to half 0), and so do its free images; so each half covers the whole range of turns
// the session swept, and a turntable position that every camera saw in the same order lands in
// one half for all of them.
//
// Comparison, per camera: d = state_0 - state_1 (CameraStateCovariance's order: intrinsics,
// rotation phi with C_b_k,0 = Exp(phi) C_b_k,1, r_b_bk), S = cov_0 + cov_1 (independent
// halves), chi2 = d^T S^-1 d over the parameters both halves estimated (S whitened to a
// correlation matrix; directions with eigenvalue below 1e-10 of its largest are dropped and
// not counted as degrees of freedom). A camera passes when P(chi-square >= chi2) >= kMinPValue:
// on an honest covariance that fails one camera in 1000; a camera moved between the halves by
// much more than its sigma fails.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "host/calib/core/calib_types.h"

namespace mfns::host {

inline constexpr double kCrossValidationMinPValue = 1e-3;

// The half (0 or 1) of every view of `in` (CalibInput::views order), by the rule above.
std::vector<int> CrossValidationHalves(const CalibInput& in);

// `in` with only the views of half `half` (cameras, target, gauge and angle sigma kept;
// skipped images left out).
CalibInput HalfInput(const CalibInput& in, const std::vector<int>& halves, int half);

// One block of a camera's state compared: chi-square and its degrees of freedom.
struct ChiSquareBlock {
  double chi2 = 0.0;
  int dof = 0;
  double p_value = 1.0;
};

struct CameraCrossValidation {
  std::string name;
  int images[2] = {0, 0};                         // views of this camera in each half
  double rotation_deg = 0.0;                      // |phi|, the angle between the halves' C_k_b
  double rotation_sigma_deg = 0.0;                // sqrt(trace S_phi): what |phi| should be, RMS
  double position_mm = 0.0;                       // |r_b_bk,0 - r_b_bk,1|
  double position_sigma_mm = 0.0;                 // sqrt(trace S_r)
  ChiSquareBlock intrinsics, rotation, position;  // each block alone (diagnosis)
  ChiSquareBlock all;                             // the joint state: decides pass/fail
  bool pass = false;
};

struct CrossValidation {
  std::vector<CameraCrossValidation> cameras;  // CalibInput::cameras order
  bool pass = false;                           // every camera passes
  std::array<int, 2> views = {0, 0};
};

// Compares two calibrations of the same cameras (same order) by their covariances. A camera
// without a covariance in either half (all zero) gets dof 0 and fails: it cannot be checked.
CrossValidation CompareHalves(const RigCalibration& half0, const RigCalibration& half1);

// One line per camera and a verdict, for stderr; and the CSV written as crossval.csv
// (camera,images_0,images_1,rotation_deg,rotation_sigma_deg,position_mm,position_sigma_mm,
// chi2_intrinsics,dof_intrinsics,chi2_rotation,dof_rotation,chi2_position,dof_position,chi2,dof,
// p_value,pass).
std::string FormatCrossValidation(const CrossValidation& cv);
// The failed cameras in a few words ("camera x: chi2 812 for 14 dof, p 1.2e-160; ..."), for a
// one-line error.
std::string FailedCameras(const CrossValidation& cv);
std::string FormatCrossValidationCsv(const CrossValidation& cv);

}  // namespace mfns::host
