// mfns-calib's command line, parsed without running anything (issue 14): the one definition of
// every subcommand and option of the tool, used by mfns-calib (mfns_calib_main.cc, which then
// runs the command) and by its fuzz target (tests/fuzz/host_cli_fuzz.cc). Needs CLI11 only, so
// that the fuzz preset compiles it without OpenCV or Ceres.
#pragma once

#include <CLI/CLI.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "host/calib/app/rig_method.h"
#include "host/core/target.h"

namespace mfns::host {

struct RigCommandOptions {
  std::string dataset;
  std::string out_dir;
  std::string method = "ml";
  bool free_k3 = false;
  double huber_px = 1.0;
  std::vector<double> mount_mm;  // r_p_pb (3 numbers); default: truth.yaml's, else 0
  double angle_sigma_arcsec = 8.0;  // default: truth.yaml's turntable_angle_sigma_arcsec when > 0
  bool angle_sigma_set = false;
  std::string reference_camera = "z";
  bool all_a10_rows = false;
  int jobs = 2;
  bool fast_detect = false;
  // corner_refine.h's model fit after findChessboardCornersSB or libapriltag: on by default
  // (--no-refine-corners: the detector's corners); --fast-detect leaves it out unless --refine-corners is given (RefineCorners).
  bool refine_corners = true;
  bool refine_corners_given = false;  // --refine-corners or --no-refine-corners was on the command line
  std::string rig_id;  // default: truth-rig.yaml's rig id, else "mfns-calibrated"
  std::uint64_t generation = 0;  // the command line's --generation through ParseGenerationOption
  bool generation_set = false;
  bool no_covariance = false;
  bool compare = false;  // also run the other methods on the same corners; compare.csv against the truth
  bool cross_validate = false;  // two halves calibrated apart and compared (uncertainty/cross_validation.h)
  // Corners from a CSV (camera,image,corner,u_px,v_px: the dataset's corners.csv format, e.g.
  // from another detector) instead of detecting them; and the corners used, written out.
  std::string corners_csv;
  std::string write_corners_csv;
};

struct IntrinsicsCommandOptions {
  std::string target;
  std::vector<std::string> images;
  std::string out_dir;
  std::string camera = "camera";
  bool free_k3 = false;
  bool fast_detect = false;
  bool refine_corners = true;  // as RigCommandOptions'
  bool refine_corners_given = false;
};

// `mfns-calib survey --rig RIG.yaml --out DIR RECORDING...` (host/calib/survey/survey_command.h).
struct SurveyCommandOptions {
  std::string rig_path;
  std::string out_dir;
  std::vector<std::string> recordings;
  std::vector<double> initial_pose;   // X,Y,Z mm, ROLL,PITCH,YAW deg (as mfns-navd's --initial-pose)
  std::vector<double> initial_sigma;  // MM,DEG (default 10 mm, 1 deg, as mfns-navd's)
  double sigma_px = 0.15;             // navd's --sigma-px: the navigator's centroid noise
  std::string rig_id;                 // default: the input rig's id
  std::uint64_t generation = 0;       // calibration.bin's; default UTC seconds now
  bool generation_set = false;
  int jobs = 2;
  bool refine_cameras = false;        // also refine each camera's mounting (SurveyOptions)
  bool turntable = false;             // each recording turns about one fixed point (pivot_group)
  // The first recording's turntable placement, surveyed (TurntablePlacement; only with
  // --turntable): its centre (mm, world) and 1-sigma (mm; default the rig's beacon_sigma_mm), its
  // rotation axis (world, any length) and 1-sigma (deg).
  std::vector<double> turntable_centre_mm;
  double turntable_centre_sigma_mm = 0.0;
  bool turntable_centre_sigma_set = false;
  std::vector<double> turntable_axis;
  double turntable_axis_sigma_deg = 5.0 / 3600.0;
  bool turntable_axis_sigma_set = false;
  // The same point in the body frame (the mount, mm) and its 1-sigma (mm; required with it).
  std::vector<double> turntable_mount_mm;
  double turntable_mount_sigma_mm = 0.0;
  bool turntable_mount_sigma_set = false;
  // Or each recording's placement from a file (turntable_placement_yaml.h), in the recordings'
  // order; "none" for a recording without one; fewer files than recordings: the rest have none.
  std::vector<std::string> turntable_placements;
  std::string command_line;  // for report.html (the tool sets it)
};

// A --generation value: a whole number 0..2^64-1 in decimal digits; anything else ("-1", "1e3",
// "x", 2^64) is a UserError naming the option (CLI11 wrapped "-1" to 2^64-1, refusing every
// later flash as "not newer").
std::uint64_t ParseGenerationOption(const std::string& text);

// mfns-calib's command line: the subcommand given and the options of each.
struct CalibCommandLine {
  std::string command;  // blob, inspect, paper-rig, rig, intrinsics or survey
  std::string rig_path;   // blob RIG
  std::string out_path;   // blob --out, paper-rig --out
  std::string blob_path;  // inspect BLOB
  std::uint64_t generation = 0;  // blob --generation through ParseGenerationOption
  bool generation_set = false;   // else the tool takes UTC seconds now
  RigCommandOptions rig;
  IntrinsicsCommandOptions intrinsics;
  SurveyCommandOptions survey;
};

// Defines mfns-calib's subcommands and options on `app` (a fresh one) and parses argv into *cl;
// runs nothing. Throws what app.parse throws (CLI::ParseError, --help included: app.exit(e)
// prints it), and UserError for a value CLI11 takes that the tool does not (--generation).
void ParseCalibCommandLine(CLI::App& app, int argc, char** argv, CalibCommandLine* cl);

// The checks each command makes on its options before it reads or writes anything (issue 14; the
// commands call them first, host_cli_fuzz after each parse): UserError, one line naming the option.
// `rig`: --out, --huber-px, --angle-sigma-arcsec, --jobs, --mount-mm and --method (returned);
// --cross-validate only with --method ml and its covariance.
RigMethod ValidateRigCommand(const RigCommandOptions& o);
// Whether the corners are refined: refine_corners, except under --fast-detect (a quick look)
// where only an explicit --refine-corners turns it on.
bool RefineCorners(bool refine_corners, bool given, bool fast_detect);
// Whether findChessboardCornersSB runs with CALIB_CB_ACCURACY (an upsampled sub-pixel search,
// ~3.5x its time): only when its corners are the final ones. The refinement converges to the same
// corners from SB's plain ones (0.0036 px both ways on paper-calibration; docs/calibration.md).
bool SbAccuracy(bool fast_detect, bool refine_corners);
// `intrinsics`: --out, --target (returned, parsed) and the images.
CalibrationTarget ValidateIntrinsicsCommand(const IntrinsicsCommandOptions& o);
// `survey`: --out, --rig, the recordings, --initial-pose (6 finite numbers), --initial-sigma (2
// positive), --sigma-px, --jobs; --turntable-centre-mm (3 finite numbers), --turntable-axis (3
// finite, not all 0), --turntable-mount-mm (3 finite numbers, its sigma required) and their
// sigmas (positive), each only with --turntable and a sigma only with its value;
// --turntable-placement only with --turntable, not with those, at most one per recording (the
// files are read by the command).
void ValidateSurveyCommand(const SurveyCommandOptions& o);

}  // namespace mfns::host
