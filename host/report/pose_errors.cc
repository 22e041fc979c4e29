#include "host/report/pose_errors.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "common/rotation/rotation.h"
#include "host/util/csv_table.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

std::map<long, std::size_t> IndexByFrame(const CsvTable& t) {
  std::map<long, std::size_t> index;
  const int col = t.Column("frame");
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (!index.emplace(std::lround(t.Number(i, col)), i).second)
      throw UserError(t.source() + ":" + std::to_string(t.Line(i)) + ": frame " + t.Cell(i, col) + " appears twice");
  }
  return index;
}

constexpr std::array<const char*, 6> kBoundCols = {"sigma_x_mm", "sigma_y_mm", "sigma_z_mm",
                                                   "sigma_roll_deg", "sigma_pitch_deg", "sigma_yaw_deg"};

}  // namespace

PoseSeries LoadPoseSeries(const std::filesystem::path& truth_csv, const std::filesystem::path& poses_csv,
                          const std::filesystem::path& crb_csv) {
  const CsvTable truth = CsvTable::Read(truth_csv);
  const CsvTable crb = crb_csv.empty() ? CsvTable::Parse("frame\n", "<none>") : CsvTable::Read(crb_csv);
  const CsvTable est = CsvTable::Read(poses_csv);
  const auto est_index = IndexByFrame(est);
  const auto crb_index = IndexByFrame(crb);

  PoseSeries series;
  series.pose_rows = est.size();
  std::vector<int> camera_cols;
  int visible_col = -1, valid_col = -1;
  std::array<int, 6> bound_col{};
  if (!crb_csv.empty()) {
    visible_col = crb.Column("n_visible");
    valid_col = crb.Column("valid");
    for (std::size_t a = 0; a < 6; ++a) bound_col[a] = crb.Column(kBoundCols[a]);
    // Per-camera columns are n_<camera> between n_visible and valid (render_run.h).
    for (int c = visible_col + 1; c < valid_col; ++c) {
      const std::string& h = crb.header()[static_cast<std::size_t>(c)];
      if (h.rfind("n_", 0) != 0) continue;
      series.cameras.push_back(h.substr(2));
      camera_cols.push_back(c);
    }
  }
  std::array<int, 6> truth_col{}, est_col{};
  for (std::size_t a = 0; a < 6; ++a) {
    truth_col[a] = truth.Column(kPoseAxes[a]);
    est_col[a] = est.Column(kPoseAxes[a]);
  }
  const int frame_col = truth.Column("frame"), status_col = est.Column("status");
  const int nb_col = est.Column("n_beacons"), rms_col = est.Column("rms_px");

  for (std::size_t t = 0; t < truth.size(); ++t) {
    PoseSample s;
    s.frame = std::lround(truth.Number(t, frame_col));
    s.yaw_true_deg = truth.Number(t, truth_col[5]);
    if (const auto c = crb_index.find(s.frame); c != crb_index.end()) {
      s.n_visible = static_cast<int>(std::lround(crb.Number(c->second, visible_col)));
      for (int col : camera_cols) s.visible_per_camera.push_back(static_cast<int>(std::lround(crb.Number(c->second, col))));
      s.bound_valid = crb.Number(c->second, valid_col) != 0;
      for (std::size_t a = 0; a < 6; ++a) s.bound[a] = crb.Number(c->second, bound_col[a]);
      if (s.bound_valid)
        for (double b : s.bound) s.bound_valid = s.bound_valid && std::isfinite(b);
    }
    if (const auto e = est_index.find(s.frame); e != est_index.end()) {
      s.status = est.Cell(e->second, status_col);
      if (s.status != "fix" && s.status != "degraded" && s.status != "lost")
        throw UserError(est.source() + ":" + std::to_string(est.Line(e->second)) + ": unknown status '" + s.status + "'");
      s.n_beacons = static_cast<int>(std::lround(est.Number(e->second, nb_col)));
      s.rms_px = est.Number(e->second, rms_col);
      if (s.status != "lost") {
        for (std::size_t a = 0; a < 6; ++a) {
          const double d = est.Number(e->second, est_col[a]) - truth.Number(t, truth_col[a]);
          s.error[a] = a >= 3 ? Wrap180Deg(d) : d;
        }
        const auto euler = [&](const CsvTable& table, std::size_t row, const std::array<int, 6>& col) {
          return EulerToMatrix(EulerAngles{DegToRad(table.Number(row, col[3])), DegToRad(table.Number(row, col[4])),
                                           DegToRad(table.Number(row, col[5]))});
        };
        s.attitude_error_deg =
            RadToDeg(LogSO3(euler(est, e->second, est_col) * euler(truth, t, truth_col).transpose()).norm());
      }
    }
    series.samples.push_back(std::move(s));
  }
  return series;
}

namespace {
bool Posed(const PoseSample& s, bool include_degraded) {
  return s.status == "fix" || (include_degraded && s.status == "degraded");
}
}  // namespace

std::set<long> CommonPosedFrames(const std::vector<const PoseSeries*>& series, bool include_degraded) {
  std::set<long> common;
  for (std::size_t k = 0; k < series.size(); ++k) {
    std::set<long> posed;
    for (const PoseSample& s : series[k]->samples)
      if (Posed(s, include_degraded) && (k == 0 || common.count(s.frame) > 0)) posed.insert(s.frame);
    common = std::move(posed);
  }
  return common;
}

PoseSummary SummarizePoses(const PoseSeries& series, bool include_degraded, const std::set<long>* only_frames,
                           bool require_bound) {
  PoseSummary r;
  std::array<double, 6> sum{}, sum2{}, bound_var{};
  std::array<int, 6> bound_n{};
  for (const PoseSample& s : series.samples) {
    ++r.frames;
    const bool three = s.n_visible >= 3;
    r.frames_3plus += three;
    if (s.status.empty()) {
      ++r.missing;
      continue;
    }
    if (s.status == "lost") {
      ++r.lost;
      continue;
    }
    (s.status == "fix" ? r.fixes : r.degraded) += 1;
    r.posed_3plus += three;
    if (s.status == "fix") r.fixes_3plus += three;
    if (!Posed(s, include_degraded)) continue;
    if (only_frames != nullptr && only_frames->count(s.frame) == 0) continue;
    if (require_bound && !s.bound_valid) continue;
    ++r.used;
    double pos2 = 0.0;
    for (std::size_t a = 0; a < 6; ++a) {
      sum[a] += s.error[a];
      sum2[a] += s.error[a] * s.error[a];
      if (a < 3) pos2 += s.error[a] * s.error[a];
      if (s.bound_valid) {
        bound_var[a] += s.bound[a] * s.bound[a];
        ++bound_n[a];
      }
    }
    r.worst_position_mm = std::max(r.worst_position_mm, std::sqrt(pos2));
    r.worst_attitude_deg = std::max(r.worst_attitude_deg, s.attitude_error_deg);
  }
  for (std::size_t a = 0; a < 6; ++a) {
    AxisSummary& x = r.axes[a];
    x.n = r.used;
    if (r.used == 0) continue;
    const double n = r.used;
    x.mean = sum[a] / n;
    x.rms = std::sqrt(sum2[a] / n);
    x.std = r.used > 1 ? std::sqrt(std::max(0.0, (sum2[a] - n * x.mean * x.mean) / (n - 1))) : 0.0;
    x.bound_rms = bound_n[a] > 0 ? std::sqrt(bound_var[a] / bound_n[a]) : 0.0;
  }
  return r;
}

}  // namespace mfns::host
