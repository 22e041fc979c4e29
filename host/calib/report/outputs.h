// What `mfns-calib rig` writes into --out DIR, each file atomically (host/util/atomic_file.h):
//   rig.yaml            the rig file of DESIGN.md with sigma (cameras without a rig estimate are
//                       written with C_k_b = I, r_b_bk = 0 and a note in the report)
//   calibration.bin     the parameter blob (common/blob)
//   camchain.yaml       Kalibr style: per camera T_cam_body (4x4, body -> camera, m; Kalibr's
//                       T_cam_imu with the body in the IMU's place), T_cn_cnm1 (camera n from
//                       camera n-1), intrinsics [fu, fv, pu, pv], distortion_coeffs radtan
//                       [k1, k2, p1, p2], resolution
//   camera-<name>.yaml  OpenCV FileStorage: camera_matrix, distortion_coefficients (k1 k2 p1 p2
//                       k3), their sigma, RMS, per-view RMS, T_cam_body
//   report.html         self-contained: parameter table with sigma, residual scatter and
//                       histogram per camera, per-view RMS, turntable-angle residuals, skipped
//                       images and why, notes; against the truth when the dataset has one; the
//                       projection uncertainty per camera (a heat map, when there is a
//                       covariance) and the cross-validation (when run)
//   crossval.csv        the cross-validation per camera (when run; cross_validation.h)
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "common/rig/rig.h"
#include "host/calib/core/calib_types.h"
#include "host/calib/core/kinematics.h"
#include "host/calib/uncertainty/cross_validation.h"

namespace mfns::host {

struct ReportContext {
  std::string title = "MFNS rig calibration";
  std::string dataset;        // path, shown in the report
  std::string command_line;   // shown in the report
  std::string rig_id = "mfns-calibrated";
  std::uint64_t generation = 0;
  const Rig* truth_rig = nullptr;               // simulation truth, when known
  const TurntableMount* truth_mount = nullptr;
  const CrossValidation* cross_validation = nullptr;  // --cross-validate's result, when run
};

// The head of a report page up to <body>: doctype, title (escaped) and the reports' shared style
// (tables, headings, class "bad"), plus extra_css. report.html of `rig` and of `survey` use it.
std::string ReportPageHead(const std::string& title, const std::string& extra_css = "");

// The rig file contents (with sigma) of a calibration.
Rig ToRig(const RigCalibration& rig, const std::string& rig_id);

std::string FormatCamchainYaml(const RigCalibration& rig);

// One camera's OpenCV FileStorage YAML. view_names/view_rms (optional, same length) list the
// per-view RMS; with_extrinsics adds T_cam_body and its sigma.
std::string FormatOpenCvCameraYaml(const CameraResult& cam, const std::vector<std::string>& view_names,
                                   const std::vector<double>& view_rms, bool with_extrinsics);

std::string FormatReportHtml(const RigCalibration& rig, const CalibInput& in, const ReportContext& ctx);

// Writes every file above into out_dir (created if missing). Throws UserError. Everything is
// formatted and the rig validated before the first write, and rig.yaml is written last, so a
// failed run never replaces a previous rig.yaml (other files are each replaced atomically).
// A failed cross-validation writes only report.html and crossval.csv (the diagnosis), then
// throws: a rig whose halves disagree never replaces rig.yaml, calibration.bin or the others.
void WriteRigOutputs(const std::filesystem::path& out_dir, const RigCalibration& rig, const CalibInput& in,
                     const ReportContext& ctx);

}  // namespace mfns::host
