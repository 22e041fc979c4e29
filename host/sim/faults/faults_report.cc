// The fault campaign as a markdown table and one SVG figure per fault (faults.h).
#include <cmath>
#include <cstdio>
#include <sstream>

#include "host/sim/analysis/svg_plot.h"
#include "host/sim/faults/faults.h"

namespace mfns::host {
namespace {

std::string Recovery(const FaultResult& r, double period_s) {
  if (r.run.fault.kind == FaultKind::kUnplug) return "- (never ends)";
  if (r.recovery_sets < 0) return "no fix after it";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%d (%.2f s)", r.recovery_sets, r.recovery_sets * period_s);
  return buf;
}

std::string HealthMoved(const FaultResult& r) {
  std::string s;
  for (const HealthCount& h : r.health_moved) {
    // (fixes/degraded/lost are the status columns already)
    if (h.name == "fixes" || h.name == "degraded" || h.name == "lost") continue;
    s += (s.empty() ? "" : ", ") + h.name + (h.value > 0 ? " +" : " ") + std::to_string(h.value);
  }
  if (!r.run.reload_said.empty()) s += (s.empty() ? "" : "; ") + std::string("reload ") + r.run.reload_said;
  return s.empty() ? "nothing" : s;
}

int Count(const FaultRun& run, fw::NavStatus status) {
  int n = 0;
  for (const FaultFrame& f : run.frames) n += f.status == status;
  return n;
}

}  // namespace

std::string FormatFaultTable(const FaultCampaign& c) {
  std::ostringstream o;
  const FaultRun& b = c.baseline;
  o << "Baseline (no fault): " << b.frames.size() << " frame sets, " << Count(b, fw::NavStatus::kFix) << " fix, "
    << Count(b, fw::NavStatus::kDegraded) << " degraded, " << Count(b, fw::NavStatus::kLost) << " lost";
  if (c.cold_first_fix >= 0) o << "; cold (no start pose): first fix at frame set " << c.cold_first_fix;
  o << ".\n\n";
  o << "| fault | injected | degraded vs baseline | lost vs baseline | recovery: frame sets to the next fix (s) | wrong fixes | wrong degraded | health reported (vs baseline) |\n";
  o << "|---|---|---|---|---|---|---|---|\n";
  for (const FaultResult& r : c.results)
    o << "| " << r.run.fault.name << " | " << r.run.fault.Describe(c.camera_names.at(static_cast<std::size_t>(r.run.fault.camera))) << " | " << r.degraded_vs_baseline << " | "
      << r.lost_vs_baseline << " | " << Recovery(r, c.period_s) << " | " << r.wrong_fixes << " | " << r.wrong_degraded
      << " | " << HealthMoved(r) << " |\n";
  return o.str();
}

std::string FormatFaultTrace(const FaultCampaign& c) {
  std::ostringstream o;
  o << "fault,frame,t_s,status,reason,position_error_mm,attitude_error_deg,wrong\n";
  const auto rows = [&o](const FaultRun& run) {
    for (const FaultFrame& f : run.frames) {
      char buf[160];
      std::snprintf(buf, sizeof(buf), "%d,%.4f,%s,%s,%.3f,%.4f,%d", f.frame, f.t_s, fw::ToString(f.status),
                    fw::ToString(f.reason), f.position_error_m * 1e3, f.attitude_error_rad * 180.0 / 3.14159265358979323846,
                    f.wrong ? 1 : 0);
      o << run.fault.name << "," << buf << "\n";
    }
  };
  rows(c.baseline);
  for (const FaultResult& r : c.results) rows(r.run);
  return o.str();
}

std::string FaultFigureSvg(const FaultResult& r, const FaultRun& baseline, double period_s) {
  SvgPlot p;
  p.title = "Fault " + r.run.fault.name + ": position error and status";
  p.x_label = "time (s)";
  p.y_label = "position error (mm)";
  p.dots_legend = "this run: fix blue, degraded orange, lost red (at 0)";
  p.line_legend = "the same run without the fault";
  for (const FaultFrame& f : r.run.frames) {
    p.dots_x.push_back(f.t_s);
    const bool lost = f.status == fw::NavStatus::kLost;
    p.dots_y.push_back(lost ? 0.0 : f.position_error_m * 1e3);
    p.dots_fill.push_back(lost ? "#d62728" : f.status == fw::NavStatus::kDegraded ? "#ff7f0e" : "#1f77b4");
  }
  for (const FaultFrame& f : baseline.frames) {
    p.line_x.push_back(f.t_s);
    p.line_y.push_back(f.status == fw::NavStatus::kLost ? std::nan("") : f.position_error_m * 1e3);
  }
  const FaultSpec& s = r.run.fault;
  const double t_end = s.kind == FaultKind::kUnplug ? r.run.frames.back().t_s : (s.last + 1) * period_s;
  p.shaded_x.push_back({s.first * period_s, std::max(t_end, (s.first + 0.3) * period_s)});
  p.shaded_legend = "the fault";
  return RenderSvg(p);
}

}  // namespace mfns::host
