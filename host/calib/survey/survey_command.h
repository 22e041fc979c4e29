// `mfns-calib survey --rig RIG.yaml --out DIR [options] RECORDING...` (issue 16): every frame set
// of each recording identified and posed by mfns-navd's own loop (replay source, detection,
// navigator; PoseRecording), then the map refined (AdjustMap, survey.h). Outputs in DIR, each
// written atomically (nothing is written when anything fails):
//   rig.yaml          the input rig with the refined map; beacon_sigma_mm one per beacon (its
//                     largest per-axis 1-sigma; unseen beacons keep the survey's)
//   calibration.bin   its parameter blob (common/blob; format version 2: per-beacon sigmas)
//   survey.csv        per beacon: index, surveyed and refined position (mm), 1-sigma (mm),
//                     shift (mm and survey sigmas), observations, frame sets, residual RMS (px),
//                     moved (1: inconsistent with the survey by more than 5 sigma), seen
//   report.html       the same per beacon, a chart of the corrections, residuals per camera,
//                     beacons never seen and "moved?" (survey_report.h)
// Progress on stderr. Throws UserError (one line naming the file or option).
#pragma once

#include <filesystem>
#include <iosfwd>
#include <vector>

#include "common/rig/rig.h"
#include "host/calib/app/calib_cli.h"
#include "host/calib/survey/survey.h"

namespace mfns::host {

struct RecordingOptions {
  double sigma_px = 0.15;  // the navigator's centroid noise (mfns-navd's --sigma-px)
  bool has_initial_pose = false;
  BodyPose initial_pose;
  double initial_sigma_m = 0.01, initial_sigma_rad = 0.0175;
};

struct RecordingSummary {
  int frame_sets = 0;  // frame sets read
  int fixes = 0;       // posed as fix: the ones the survey uses
};

// The fixes of one recording (frames directory) with the identities and centroids their solve
// used, as mfns-navd on the flyer would find them (its NavLoop over a ReplaySource with the
// default configuration). Throws UserError naming the directory when the replay cannot start.
std::vector<SurveyFrameSet> PoseRecording(const Rig& rig, const std::filesystem::path& dir, const RecordingOptions& o,
                                          RecordingSummary* summary);

// The survey.csv text of a result (see above).
std::string FormatSurveyCsv(const SurveyResult& r, double moved_sigmas);

// Runs the command; the summary and progress go to log.
SurveyResult RunSurveyCommand(const SurveyCommandOptions& o, std::ostream& log);

}  // namespace mfns::host
