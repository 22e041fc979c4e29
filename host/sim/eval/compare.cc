#include "host/sim/eval/compare.h"

#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <vector>

#include "common/rotation/rotation.h"
#include "host/util/csv_table.h"

namespace mfns::host {

CompareResult ComparePoses(const std::filesystem::path& sim_dir, const std::filesystem::path& poses_csv) {
  const CsvTable truth = CsvTable::Read(sim_dir / "truth.csv");
  const CsvTable crb = CsvTable::Read(sim_dir / "crb.csv");
  const CsvTable est = CsvTable::Read(poses_csv);
  const std::array<const char*, 6> truth_cols = {"x_mm", "y_mm", "z_mm", "roll_deg", "pitch_deg", "yaw_deg"};
  const std::array<const char*, 6> bound_cols = {"sigma_x_mm", "sigma_y_mm", "sigma_z_mm", "sigma_roll_deg",
                                                 "sigma_pitch_deg", "sigma_yaw_deg"};

  // Statistics of nothing would print as 0.000 mm, a perfect navigator.
  if (est.size() == 0) throw UserError(est.source() + ": no poses (only a header); nothing to compare");
  if (truth.size() == 0) throw UserError(truth.source() + ": no frames (only a header); nothing to compare");
  std::map<long, std::size_t> est_row, crb_row;
  const int est_frame = est.Column("frame"), crb_frame = crb.Column("frame");
  for (std::size_t i = 0; i < est.size(); ++i) est_row[std::lround(est.Number(i, est_frame))] = i;
  for (std::size_t i = 0; i < crb.size(); ++i) crb_row[std::lround(crb.Number(i, crb_frame))] = i;
  const int status_col = est.Column("status");
  const int visible_col = crb.Column("n_visible"), valid_col = crb.Column("valid");

  CompareResult r;
  std::array<std::vector<double>, 6> errors;
  std::array<double, 6> bound_var{};
  const int truth_frame = truth.Column("frame");
  for (std::size_t t = 0; t < truth.size(); ++t) {
    const long frame = std::lround(truth.Number(t, truth_frame));
    ++r.frames;
    const auto c = crb_row.find(frame);
    const bool three = c != crb_row.end() && crb.Number(c->second, visible_col) >= 3;
    r.frames_3plus += three;
    const auto e = est_row.find(frame);
    if (e == est_row.end()) {
      ++r.missing;
      continue;
    }
    const std::string& status = est.Cell(e->second, status_col);
    if (status == "fix") {
      ++r.fixes;
      r.fixes_3plus += three;
    } else if (status == "degraded") {
      ++r.degraded;
    } else if (status == "lost") {
      ++r.lost;
      continue;
    } else {
      throw UserError(est.source() + ":" + std::to_string(est.Line(e->second)) + ": unknown status '" + status + "'");
    }
    if (status != "fix" || c == crb_row.end() || crb.Number(c->second, valid_col) == 0) continue;
    ++r.compared;
    double pos2 = 0, att2 = 0;
    for (int a = 0; a < 6; ++a) {
      double err = est.Number(e->second, est.Column(truth_cols[static_cast<std::size_t>(a)])) -
                   truth.Number(t, truth.Column(truth_cols[static_cast<std::size_t>(a)]));
      if (a >= 3) err = Wrap180Deg(err);
      errors[static_cast<std::size_t>(a)].push_back(err);
      const double s = crb.Number(c->second, crb.Column(bound_cols[static_cast<std::size_t>(a)]));
      bound_var[static_cast<std::size_t>(a)] += s * s;
      (a < 3 ? pos2 : att2) += err * err;
    }
    r.worst_position_mm = std::max(r.worst_position_mm, std::sqrt(pos2));
    r.worst_attitude_deg = std::max(r.worst_attitude_deg, std::sqrt(att2));
  }
  if (r.missing == r.frames)
    throw UserError(est.source() + ": none of its " + std::to_string(est.size()) + " frames is in " + truth.source());
  for (std::size_t a = 0; a < 6; ++a) {
    const auto& v = errors[a];
    if (v.empty()) continue;
    AxisStats& s = r.axes[a];
    double sum = 0, sum2 = 0;
    for (double x : v) {
      sum += x;
      sum2 += x * x;
    }
    const double n = static_cast<double>(v.size());
    s.mean = sum / n;
    s.rms = std::sqrt(sum2 / n);
    s.std = v.size() > 1 ? std::sqrt(std::max(0.0, (sum2 - n * s.mean * s.mean) / (n - 1))) : 0.0;
    s.bound_rms = std::sqrt(bound_var[a] / n);
    s.ratio = s.bound_rms > 0 ? s.rms / s.bound_rms : 0.0;
  }
  return r;
}

std::string FormatCompare(const CompareResult& r) {
  std::ostringstream o;
  char line[256];
  std::snprintf(line, sizeof(line),
                "frame sets %d: >= 3 beacons visible %d, fix in %d of those (%.1f%%); fix %d, degraded %d, lost %d, "
                "missing %d; compared %d\n",
                r.frames, r.frames_3plus, r.fixes_3plus, r.frames_3plus ? 100.0 * r.fixes_3plus / r.frames_3plus : 0.0,
                r.fixes, r.degraded, r.lost, r.missing, r.compared);
  o << line;
  if (r.compared == 0) {  // no error statistics: never print them as 0.000
    o << "no fix with a valid bound to compare: no error statistics\n";
    return o.str();
  }
  o << "axis          mean        std        rms   CRB rms   rms/CRB\n";
  for (std::size_t a = 0; a < 6; ++a) {
    const AxisStats& s = r.axes[a];
    std::snprintf(line, sizeof(line), "%-10s %9.4f  %9.4f  %9.4f  %8.4f  %8.2f\n", kAxisNames[a], s.mean, s.std, s.rms,
                  s.bound_rms, s.ratio);
    o << line;
  }
  std::snprintf(line, sizeof(line), "worst position error %.3f mm, worst attitude error %.4f deg\n", r.worst_position_mm,
                r.worst_attitude_deg);
  o << line;
  return o.str();
}

}  // namespace mfns::host
