// report.html of `mfns-calib survey` (issue 16): one self-contained page (inline SVG, no
// scripts) with the inputs, the per-beacon correction and 1-sigma (table id "beacons", chart id
// "corrections"), the residuals per camera (table id "cameras"), the beacons never seen (list id
// "unseen") and those inconsistent with the survey by more than 5 sigma (list id "moved").
#pragma once

#include <string>
#include <vector>

#include "common/rig/rig.h"
#include "host/calib/survey/survey.h"

namespace mfns::host {

struct SurveyReportContext {
  std::string title = "MFNS beacon-map survey";
  std::string command_line;
  std::string rig_path;
  std::vector<std::string> recordings;  // one line each: "DIR: N frame sets, M fixes"
  double moved_sigmas = 5.0;
};

std::string SurveyReportHtml(const Rig& rig, const SurveyResult& r, const SurveyReportContext& ctx);

}  // namespace mfns::host
