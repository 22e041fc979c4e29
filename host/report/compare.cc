#include "host/report/compare.h"

#include <cstdio>
#include <sstream>

#include "host/util/user_error.h"

namespace mfns::host {

PoseSummary ComparePoses(const std::filesystem::path& sim_dir, const std::filesystem::path& poses_csv) {
  const std::filesystem::path truth_csv = sim_dir / "truth.csv";
  const PoseSeries series = LoadPoseSeries(truth_csv, poses_csv, sim_dir / "crb.csv");
  if (series.pose_rows == 0) throw UserError(poses_csv.string() + ": no poses (only a header); nothing to compare");
  if (series.samples.empty()) throw UserError(truth_csv.string() + ": no frames (only a header); nothing to compare");
  const PoseSummary r = SummarizePoses(series, /*include_degraded=*/false, nullptr, /*require_bound=*/true);
  if (r.missing == r.frames)
    throw UserError(poses_csv.string() + ": none of its " + std::to_string(series.pose_rows) + " frames is in " +
                    truth_csv.string());
  return r;
}

std::string FormatCompare(const PoseSummary& r) {
  std::ostringstream o;
  char line[256];
  std::snprintf(line, sizeof(line),
                "frame sets %d: >= 3 beacons visible %d, fix in %d of those (%.1f%%); fix %d, degraded %d, lost %d, "
                "missing %d; compared %d\n",
                r.frames, r.frames_3plus, r.fixes_3plus, r.frames_3plus ? 100.0 * r.fixes_3plus / r.frames_3plus : 0.0,
                r.fixes, r.degraded, r.lost, r.missing, r.used);
  o << line;
  if (r.used == 0) {  // no error statistics: never print them as 0.000
    o << "no fix with a valid bound to compare: no error statistics\n";
    return o.str();
  }
  o << "axis          mean        std        rms   CRB rms   rms/CRB\n";
  for (std::size_t a = 0; a < 6; ++a) {
    const AxisSummary& s = r.axes[a];
    const double ratio = s.bound_rms > 0 ? s.rms / s.bound_rms : 0.0;
    std::snprintf(line, sizeof(line), "%-10s %9.4f  %9.4f  %9.4f  %8.4f  %8.2f\n", kPoseAxes[a], s.mean, s.std, s.rms,
                  s.bound_rms, ratio);
    o << line;
  }
  std::snprintf(line, sizeof(line), "worst position error %.3f mm, worst attitude error %.4f deg\n", r.worst_position_mm,
                r.worst_attitude_deg);
  o << line;
  return o.str();
}

}  // namespace mfns::host
