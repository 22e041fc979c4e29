#include "host/calib/app/calib_cli.h"

#include <algorithm>
#include <charconv>
#include <cmath>

#include "host/calib/core/dataset.h"
#include "host/util/cli_parse.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

CLI::App* AddRigCommand(CLI::App& app, RigCommandOptions* o, std::string* generation) {
  CLI::App* cmd = app.add_subcommand("rig", "Calibrate the rig (intrinsics, C_k_b, r_b_bk with sigma) from a turntable "
                                            "dataset (docs/calib-dataset.md)");
  cmd->add_option("dataset", o->dataset, "Dataset directory")->required();
  cmd->add_option("--out", o->out_dir, "Output directory (created if missing)")->required();
  cmd->add_option("--method", o->method, "ml (joint maximum likelihood), paper (CPC, Appendix A) or opencv-handeye")
      ->capture_default_str();
  cmd->add_flag("--free-k3", o->free_k3, "Estimate kc5 (k3); default fixed at 0 as the paper's Table 2");
  cmd->add_option("--huber-px", o->huber_px,
                  "ml: Huber loss from this many px, or from 4 x the camera's pixel sigma when smaller (0: plain least "
                  "squares)")
      ->capture_default_str();
  cmd->add_option("--mount-mm", o->mount_mm,
                  "Body origin in the platform frame r_p_pb X Y Z in mm (the measured mount; default: truth.yaml's, "
                  "else 0 0 0)")
      ->expected(3);
  cmd->add_option("--angle-sigma-arcsec", o->angle_sigma_arcsec, "Turntable angle accuracy, 1-sigma")->capture_default_str();
  cmd->add_option("--reference-camera", o->reference_camera, "paper: the camera of eq. A10")->capture_default_str();
  cmd->add_flag("--all-a10-rows", o->all_a10_rows, "paper: use all nine elements of every image in A10");
  cmd->add_option("--jobs", o->jobs, "Detection threads")->capture_default_str();
  cmd->add_flag("--fast-detect", o->fast_detect,
                "No corner refinement and findChessboardCornersSB without CALIB_CB_ACCURACY (a quick look: the "
                "detector's corners, 5-10x less exact)");
  cmd->add_flag("--refine-corners,!--no-refine-corners", o->refine_corners,
                "Fit a blurred-corner model to every checkerboard corner (SB's) or AprilGrid tag corner (libapriltag's): "
                "the default, 5-10x more exact for 0.02-0.05 s CPU per 1280x1024 image (docs/calibration.md); "
                "--no-refine-corners keeps the detector's corners (SB's with CALIB_CB_ACCURACY)")
      ->each([o](const std::string&) { o->refine_corners_given = true; });
  cmd->add_option("--rig-id", o->rig_id, "Rig id of the blob (default: the truth rig's, else mfns-calibrated)");
  cmd->add_option("--generation", *generation, "Blob generation, 0..2^64-1 (default: UTC seconds now)");
  cmd->add_flag("--no-covariance", o->no_covariance, "ml: skip the covariance (sigma 0)");
  cmd->add_option("--corners", o->corners_csv,
                  "Use these corners (CSV camera,image,corner,u_px,v_px as the dataset's corners.csv) instead of "
                  "detecting them");
  cmd->add_option("--write-corners", o->write_corners_csv, "Write the corners used (same CSV format)");
  cmd->add_flag("--compare", o->compare,
                "Also run every other method on the same corners and write compare.csv (errors against the dataset's "
                "truth)");
  cmd->add_flag("--cross-validate", o->cross_validate,
                "ml: also calibrate two halves of the images apart (each camera's images alternating) and check their "
                "difference against their covariances (chi-square per camera); on failure only report.html and "
                "crossval.csv are written, exit 1");
  return cmd;
}

void AddIntrinsicsCommand(CLI::App& app, IntrinsicsCommandOptions* o) {
  CLI::App* cmd = app.add_subcommand("intrinsics", "Zhang's intrinsics of one camera from plain target images");
  cmd->add_option("--target", o->target,
                  "checkerboard:COLSxROWS:SQUARE_MM (inner corners) or aprilgrid:COLSxROWS:TAG_MM:SPACING[:FIRST_ID]")
      ->required();
  cmd->add_option("images", o->images, "Images (PGM, PNG, ...)")->required();
  cmd->add_option("--out", o->out_dir, "Output directory (created if missing)")->required();
  cmd->add_option("--camera", o->camera, "Camera name in the outputs")->capture_default_str();
  cmd->add_flag("--free-k3", o->free_k3, "Estimate kc5 (k3); default fixed at 0");
  cmd->add_flag("--fast-detect", o->fast_detect,
                "No corner refinement and findChessboardCornersSB without CALIB_CB_ACCURACY");
  cmd->add_flag("--refine-corners,!--no-refine-corners", o->refine_corners,
                "Fit a blurred-corner model to every checkerboard or AprilGrid tag corner (the default); "
                "--no-refine-corners keeps the detector's corners")
      ->each([o](const std::string&) { o->refine_corners_given = true; });
}

CLI::App* AddSurveyCommand(CLI::App& app, SurveyCommandOptions* o, std::string* generation) {
  CLI::App* cmd = app.add_subcommand(
      "survey", "Refine the beacon map from recordings: every frame set posed by mfns-navd's pipeline, then all "
                "poses and beacons adjusted together with the surveyed map as prior");
  cmd->add_option("--rig", o->rig_path, "Rig file (YAML) with the cameras and the surveyed map (beacon_sigma_mm)")
      ->required();
  cmd->add_option("--out", o->out_dir, "Output directory (created if missing)")->required();
  cmd->add_option("recordings", o->recordings, "Frames directories (DIR/frames/<camera>/<frame:06d>.pgm)")->required();
  cmd->add_option("--initial-pose", o->initial_pose, "X,Y,Z,ROLL,PITCH,YAW (mm, deg): a known start pose")
      ->delimiter(',')
      ->allow_extra_args(false)
      ->expected(6);
  cmd->add_option("--initial-sigma", o->initial_sigma, "MM,DEG: the start pose's 1-sigma (default 10,1)")
      ->delimiter(',')
      ->allow_extra_args(false)
      ->expected(2);
  cmd->add_option("--sigma-px", o->sigma_px, "The navigator's centroid 1-sigma (px), as mfns-navd's")
      ->capture_default_str();
  cmd->add_option("--rig-id", o->rig_id, "Rig id of the outputs (default: the input rig's)");
  cmd->add_option("--generation", *generation, "calibration.bin's generation (default: UTC seconds now)");
  cmd->add_option("--jobs", o->jobs, "Threads of the adjustment")->capture_default_str();
  cmd->add_flag("--refine-cameras", o->refine_cameras,
                "Also refine each camera's mounting (C_k_b, r_b_bk; intrinsics held): with the rig's calibration "
                "sigma as prior, else in the frame of the first camera seen, which is held");
  cmd->add_flag("--turntable", o->turntable,
                "Each recording is a turntable run: the body turns about one fixed point (where the axes meet), "
                "so its poses share their position model and the beacons' depths are better determined");
  cmd->add_option("--turntable-centre-mm", o->turntable_centre_mm,
                  "X,Y,Z (mm, world): the first recording's turntable centre (where its axes meet), surveyed")
      ->delimiter(',')
      ->allow_extra_args(false)
      ->expected(3);
  cmd->add_option("--turntable-centre-sigma-mm", o->turntable_centre_sigma_mm,
                  "Its 1-sigma per coordinate (mm; default the rig's beacon_sigma_mm: the beacons' instrument)");
  cmd->add_option("--turntable-axis", o->turntable_axis,
                  "X,Y,Z (world): the first recording's turntable axis, surveyed or levelled (a run about one axis)")
      ->delimiter(',')
      ->allow_extra_args(false)
      ->expected(3);
  cmd->add_option("--turntable-axis-sigma-deg", o->turntable_axis_sigma_deg, "Its 1-sigma across it (deg)")
      ->capture_default_str();
  cmd->add_option("--turntable-mount-mm", o->turntable_mount_mm,
                  "X,Y,Z (mm, body): the first recording's turntable centre in the body frame (the mount), which "
                  "with --turntable-centre-mm also places the map along the axis")
      ->delimiter(',')
      ->allow_extra_args(false)
      ->expected(3);
  cmd->add_option("--turntable-mount-sigma-mm", o->turntable_mount_sigma_mm, "Its 1-sigma per coordinate (mm)");
  cmd->add_option("--turntable-placement", o->turntable_placements,
                  "FILE (repeatable, one per recording in order; 'none': that recording has none): a recording's "
                  "surveyed turntable placement, YAML (centre_mm, centre_sigma_mm, centre_b_mm, centre_b_sigma_mm, "
                  "axis, axis_sigma_deg; mfns-sim render writes turntable-survey.yaml)")
      ->expected(1)
      ->allow_extra_args(false)  // (one file per option: the recordings after it stay recordings)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  return cmd;
}

}  // namespace

namespace {
void ValidateTurntablePlacement(const SurveyCommandOptions& o) {
  const auto finite3 = [](const std::vector<double>& v) {
    return v.size() == 3 && std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
  };
  const bool centre = !o.turntable_centre_mm.empty(), axis = !o.turntable_axis.empty();
  if ((centre || axis || o.turntable_centre_sigma_set || o.turntable_axis_sigma_set) && !o.turntable)
    throw UserError(std::string(centre ? "--turntable-centre-mm" : axis ? "--turntable-axis" : "a turntable sigma") +
                    ": only with --turntable (a turntable run's surveyed placement)");
  if (centre && !finite3(o.turntable_centre_mm)) throw UserError("--turntable-centre-mm: expected 3 finite numbers X,Y,Z");
  if (o.turntable_centre_sigma_set && (!centre || !(o.turntable_centre_sigma_mm > 0) ||
                                       !std::isfinite(o.turntable_centre_sigma_mm)))
    throw UserError("--turntable-centre-sigma-mm: a positive number, with --turntable-centre-mm");
  if (axis && (!finite3(o.turntable_axis) ||
               std::hypot(o.turntable_axis[0], o.turntable_axis[1], o.turntable_axis[2]) == 0.0))
    throw UserError("--turntable-axis: expected 3 finite numbers X,Y,Z, not all 0");
  if (!(o.turntable_axis_sigma_deg > 0) || !std::isfinite(o.turntable_axis_sigma_deg) ||
      (o.turntable_axis_sigma_set && !axis))
    throw UserError("--turntable-axis-sigma-deg: a positive number, with --turntable-axis");
  const bool mount = !o.turntable_mount_mm.empty();
  if (mount && !o.turntable) throw UserError("--turntable-mount-mm: only with --turntable (a turntable run's surveyed placement)");
  if (mount && !finite3(o.turntable_mount_mm)) throw UserError("--turntable-mount-mm: expected 3 finite numbers X,Y,Z");
  if (mount != o.turntable_mount_sigma_set || (mount && (!(o.turntable_mount_sigma_mm > 0) ||
                                                         !std::isfinite(o.turntable_mount_sigma_mm))))
    throw UserError("--turntable-mount-sigma-mm: a positive number, required with --turntable-mount-mm");
  if (o.turntable_placements.empty()) return;
  if (!o.turntable) throw UserError("--turntable-placement: only with --turntable (a turntable run's surveyed placement)");
  if (centre || axis || mount)
    throw UserError("--turntable-placement: not with --turntable-centre-mm, --turntable-axis or --turntable-mount-mm "
                    "(put the first recording's placement in its file)");
  if (o.turntable_placements.size() > o.recordings.size())
    throw UserError("--turntable-placement: " + std::to_string(o.turntable_placements.size()) + " files for " +
                    std::to_string(o.recordings.size()) + " recordings");
}
}  // namespace

void ValidateSurveyCommand(const SurveyCommandOptions& o) {
  if (o.out_dir.empty()) throw UserError("--out DIR is required");
  if (o.rig_path.empty()) throw UserError("--rig RIG.yaml is required");
  if (o.recordings.empty()) throw UserError("no recording given");
  if (!o.initial_pose.empty()) {
    if (o.initial_pose.size() != 6) throw UserError("--initial-pose: expected X,Y,Z,ROLL,PITCH,YAW");
    for (double v : o.initial_pose)
      if (!std::isfinite(v)) throw UserError("--initial-pose: every value must be a finite number");
  }
  if (!o.initial_sigma.empty() &&
      (o.initial_sigma.size() != 2 || !(o.initial_sigma[0] > 0 && o.initial_sigma[1] > 0) ||
       !std::isfinite(o.initial_sigma[0]) || !std::isfinite(o.initial_sigma[1])))
    throw UserError("--initial-sigma: expected two positive numbers MM,DEG");
  if (!(o.sigma_px > 0) || !std::isfinite(o.sigma_px)) throw UserError("--sigma-px must be a positive number");
  if (o.jobs < 1 || o.jobs > 64) throw UserError("--jobs must be 1..64");
  ValidateTurntablePlacement(o);
}

std::uint64_t ParseGenerationOption(const std::string& text) {
  std::uint64_t value = 0;
  const char* end = text.data() + text.size();
  const auto r = std::from_chars(text.data(), end, value);
  if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos || r.ec != std::errc() || r.ptr != end)
    throw UserError("--generation: expected a whole number 0..18446744073709551615, got \"" + OneLine(text) + "\"");
  return value;
}

bool RefineCorners(bool refine_corners, bool given, bool fast_detect) { return refine_corners && (!fast_detect || given); }
bool SbAccuracy(bool fast_detect, bool refine_corners) { return !fast_detect && !refine_corners; }

RigMethod ValidateRigCommand(const RigCommandOptions& o) {
  if (o.out_dir.empty()) throw UserError("--out DIR is required");
  if (!(o.huber_px >= 0)) throw UserError("--huber-px must not be negative");
  if (!(o.angle_sigma_arcsec > 0)) throw UserError("--angle-sigma-arcsec must be positive");
  if (o.jobs < 1 || o.jobs > 64) throw UserError("--jobs must be 1..64");
  if (!o.mount_mm.empty() && o.mount_mm.size() != 3) throw UserError("--mount-mm: expected 3 numbers X Y Z");
  const RigMethod method = ParseRigMethod(o.method);
  if (o.cross_validate && (method != RigMethod::kMl || o.no_covariance))
    throw UserError("--cross-validate needs --method ml with its covariance (not --no-covariance)");
  return method;
}

CalibrationTarget ValidateIntrinsicsCommand(const IntrinsicsCommandOptions& o) {
  if (o.out_dir.empty()) throw UserError("--out DIR is required");
  if (o.target.empty()) throw UserError("--target is required");
  if (o.images.empty()) throw UserError("no images given");
  return ParseTargetSpec(o.target);
}

void ParseCalibCommandLine(CLI::App& app, int argc, char** argv, CalibCommandLine* cl) {
  app.description("MFNS calibration tools: rig calibration, intrinsics, rig files, parameter blobs");
  app.require_subcommand(1);

  std::string generation;  // ParseGenerationOption: CLI11 read "-1" as 2^64-1
  CLI::App* blob = app.add_subcommand("blob", "Turn a rig file into a parameter blob");
  blob->add_option("rig", cl->rig_path, "Rig file (YAML)")->required();
  blob->add_option("--out", cl->out_path, "Output blob file")->required();
  blob->add_option("--generation", generation,
                   "Blob generation, 0..2^64-1 (monotonically increasing; default: UTC seconds now)");

  app.add_subcommand("inspect", "Check a parameter blob and print its contents")
      ->add_option("blob", cl->blob_path, "Blob file")
      ->required();

  app.add_subcommand("paper-rig", "Write the paper's published rig (Tables 2-4) as a rig file")
      ->add_option("--out", cl->out_path, "Output rig file (YAML)")
      ->required();

  std::string rig_generation;
  CLI::App* rig = AddRigCommand(app, &cl->rig, &rig_generation);
  AddIntrinsicsCommand(app, &cl->intrinsics);
  std::string survey_generation;
  CLI::App* survey = AddSurveyCommand(app, &cl->survey, &survey_generation);

  ParseOneLine(app, argc, argv);
  cl->command = app.get_subcommands().front()->get_name();
  cl->generation_set = blob->count("--generation") > 0;
  if (cl->generation_set) cl->generation = ParseGenerationOption(generation);
  cl->rig.generation_set = rig->count("--generation") > 0;
  if (cl->rig.generation_set) cl->rig.generation = ParseGenerationOption(rig_generation);
  cl->rig.angle_sigma_set = rig->count("--angle-sigma-arcsec") > 0;
  cl->survey.generation_set = survey->count("--generation") > 0;
  if (cl->survey.generation_set) cl->survey.generation = ParseGenerationOption(survey_generation);
  cl->survey.turntable_centre_sigma_set = survey->count("--turntable-centre-sigma-mm") > 0;
  cl->survey.turntable_axis_sigma_set = survey->count("--turntable-axis-sigma-deg") > 0;
  cl->survey.turntable_mount_sigma_set = survey->count("--turntable-mount-sigma-mm") > 0;
}

}  // namespace mfns::host
