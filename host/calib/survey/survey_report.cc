#include "host/calib/survey/survey_report.h"

#include <algorithm>
#include <cstdio>
#include <sstream>

#include "common/rotation/rotation.h"
#include "host/calib/report/outputs.h"
#include "host/calib/report/svg.h"

namespace mfns::host {
namespace {

std::string Fixed(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

void BeaconTable(const SurveyResult& r, double moved_sigmas, std::ostringstream& h) {
  h << "<h2>Beacons</h2>\n<table id=\"beacons\"><tr><th>beacon</th><th>frame sets</th><th>observations</th>"
       "<th>correction x (mm)</th><th>y</th><th>z</th><th>|correction| (mm)</th><th>1-sigma x (mm)</th><th>y</th>"
       "<th>z</th><th>shift / survey sigma</th><th>residual RMS (px)</th><th class=\"l\">status</th></tr>\n";
  for (std::size_t b = 0; b < r.beacons.size(); ++b) {
    const SurveyBeacon& s = r.beacons[b];
    const Eigen::Vector3d d = (s.refined_w - s.surveyed_w) * 1e3, sg = s.Sigma() * 1e3;
    const char* status = s.observations == 0 ? "never seen" : s.shift_sigmas > moved_sigmas ? "moved?" : "ok";
    h << "<tr" << (s.shift_sigmas > moved_sigmas ? " class=\"bad\"" : "") << "><td>" << b << "</td><td>"
      << s.frame_sets << "</td><td>" << s.observations << "</td>";
    for (int k = 0; k < 3; ++k) h << "<td>" << Fixed(d(k), 3) << "</td>";
    h << "<td>" << Fixed(d.norm(), 3) << "</td>";
    for (int k = 0; k < 3; ++k) h << "<td>" << Fixed(sg(k), 3) << "</td>";
    h << "<td>" << Fixed(s.shift_sigmas, 2) << "</td><td>" << Fixed(s.rms_px, 3) << "</td><td class=\"l\">" << status
      << "</td></tr>\n";
  }
  h << "</table>\n";
}

void CorrectionChart(const SurveyResult& r, std::ostringstream& h) {
  std::vector<std::string> labels;
  std::vector<double> values;
  for (std::size_t b = 0; b < r.beacons.size(); ++b) {
    if (r.beacons[b].observations == 0) continue;
    labels.push_back(std::to_string(b));
    values.push_back((r.beacons[b].refined_w - r.beacons[b].surveyed_w).norm() * 1e3);
  }
  h << "<div id=\"corrections\">" << BarSvg(labels, values, "Correction of each seen beacon", "|refined - surveyed| (mm)")
    << "</div>\n";
}

// Residuals per camera and, when the mountings were refined (--refine-cameras), each camera's
// change and its 1-sigma (norms over the three axes).
void CameraTable(const Rig& rig, const SurveyResult& r, std::ostringstream& h) {
  const bool any_refined =
      std::any_of(r.cameras.begin(), r.cameras.end(), [](const SurveyCamera& c) { return c.refined; });
  h << "<h2>Residuals per camera</h2>\n<table id=\"cameras\"><tr><th class=\"l\">camera</th><th>observations</th>"
       "<th>residual RMS (px)</th>";
  if (any_refined)
    h << "<th class=\"l\">mounting</th><th>rotation change (deg)</th><th>1-sigma (deg)</th>"
         "<th>position change (mm)</th><th>1-sigma (mm)</th>";
  h << "</tr>\n";
  for (int k = 0; k < rig.num_cameras; ++k) {
    const auto sk = static_cast<std::size_t>(k);
    h << "<tr><td class=\"l\">" << XmlEscape(rig.cameras[sk].name.data()) << "</td><td>"
      << (sk < r.camera_observations.size() ? r.camera_observations[sk] : 0) << "</td><td>"
      << Fixed(sk < r.camera_rms_px.size() ? r.camera_rms_px[sk] : 0.0, 4) << "</td>";
    if (any_refined && sk < r.cameras.size()) {
      const SurveyCamera& c = r.cameras[sk];
      const Eigen::Matrix<double, 6, 1> sg = c.covariance.diagonal().cwiseSqrt();
      h << "<td class=\"l\">" << (c.refined ? "refined" : "held") << "</td><td>"
        << Fixed(RadToDeg(c.rotation_change_rad.norm()), 4) << "</td><td>" << Fixed(RadToDeg(sg.head<3>().norm()), 4)
        << "</td><td>" << Fixed(1e3 * c.translation_change_m.norm(), 3) << "</td><td>"
        << Fixed(1e3 * sg.tail<3>().norm(), 3) << "</td>";
    }
    h << "</tr>\n";
  }
  h << "</table>\n";
}

// A list of the beacons for which pick(beacon) holds, or "none".
template <typename Pick>
void BeaconList(const SurveyResult& r, const char* id, const char* heading, Pick pick, std::ostringstream& h) {
  h << "<h2>" << heading << "</h2>\n<ul id=\"" << id << "\">";
  int n = 0;
  for (std::size_t b = 0; b < r.beacons.size(); ++b)
    if (pick(r.beacons[b])) h << "<li>beacon " << b << "</li>", ++n;
  if (n == 0) h << "<li>none</li>";
  h << "</ul>\n";
}

}  // namespace

std::string SurveyReportHtml(const Rig& rig, const SurveyResult& r, const SurveyReportContext& ctx) {
  std::ostringstream h;
  h << ReportPageHead(ctx.title) << "<h1>" << XmlEscape(ctx.title) << "</h1>\n<table>";
  const auto row = [&](const std::string& k, const std::string& v) {
    h << "<tr><th class=\"l\">" << XmlEscape(k) << "</th><td class=\"l\">" << v << "</td></tr>";
  };
  if (!ctx.command_line.empty()) row("command", "<code>" + XmlEscape(ctx.command_line) + "</code>");
  row("rig", XmlEscape(ctx.rig_path) + " (" + XmlEscape(rig.rig_id.data()) + ", survey 1-sigma " +
                 Fixed(rig.beacon_sigma * 1e3, 3) + " mm)");
  for (const std::string& line : ctx.recordings) row("recording", XmlEscape(line));
  row("frame sets adjusted", std::to_string(r.poses.size()));
  row("observations", std::to_string(r.observations) + " (" + std::to_string(r.outliers) + " beyond the robust loss's threshold)");
  row(r.sigma_estimated ? "centroid sigma (from the residuals)" : "centroid sigma (given: too few observations to estimate it)",
      Fixed(r.sigma_px, 4) + " px; residual RMS " + Fixed(r.rms_px, 4) + " px");
  h << "</table>\n";
  BeaconTable(r, ctx.moved_sigmas, h);
  CorrectionChart(r, h);
  CameraTable(rig, r, h);
  BeaconList(r, "unseen", "Beacons never seen", [](const SurveyBeacon& b) { return b.observations == 0; }, h);
  BeaconList(r, "moved", "Inconsistent with the survey (moved?)", [](const SurveyBeacon& b) { return b.moved; }, h);
  h << "</body></html>\n";
  return h.str();
}

}  // namespace mfns::host
