// The calibration pipeline behind `mfns-calib rig`: detection over a dataset, Zhang per
// camera, the orientation of symmetric boards, then one method (ml, paper, opencv-handeye).
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

#include "host/calib/app/rig_method.h"
#include "host/calib/core/calib_types.h"
#include "host/calib/core/dataset.h"
#include "host/calib/core/kinematics.h"
#include "host/calib/detect/target_detector.h"
#include "host/calib/uncertainty/cross_validation.h"
#include "host/calib/zhang/zhang.h"

namespace mfns::host {

struct RigOptions {
  RigMethod method = RigMethod::kMl;
  bool fix_k3 = true;
  double huber_px = 1.0;
  std::string reference_camera = "z";  // paper: the camera of eq. A10
  bool paper_rows_only = true;
  bool covariance = true;
  int min_corners = 8;
  std::ostream* progress = nullptr;  // stderr in the tool
};

// Detects the target in every image of the dataset (jobs threads). Images where it fails, or
// whose size differs from the camera's first image, go to CalibInput::skipped with the reason.
// The mount (gauge) and angle sigma are left for the caller to set.
CalibInput DetectDataset(const CalibDataset& ds, const DetectOptions& detect, int jobs, std::ostream* progress);

// Zhang per camera over all its usable views, then the orientation of symmetric boards.
// Views with fewer than min_corners corners are skipped; a camera with fewer than 3 views is a
// UserError.
struct IntrinsicsStage {
  std::vector<ZhangResult> zhang;     // per camera
  std::vector<Transform> view_T_w_k;  // per view: C_w_k, r_w_wk
  std::vector<std::string> notes;
};
IntrinsicsStage PrepareViews(CalibInput* in, const RigOptions& options);

// One method on prepared views (PrepareViews' output for the same `in`).
RigCalibration SolveRig(const CalibInput& in, const IntrinsicsStage& stage, const RigOptions& options);

// PrepareViews then SolveRig (in may be pruned and relabelled).
RigCalibration CalibrateRig(CalibInput* in, const RigOptions& options);

// `mfns-calib rig --cross-validate` (uncertainty/cross_validation.h): `in` (prepared views, as
// SolveRig takes them) split into its two halves, each calibrated alone by CalibrateRig with
// `options` (method ml: the comparison needs the covariance), then compared. UserError when a
// half cannot be calibrated (e.g. a camera with fewer than 3 images in it).
CrossValidation CrossValidateRig(const CalibInput& in, const RigOptions& options);

}  // namespace mfns::host
