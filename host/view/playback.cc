#include "host/view/playback.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "common/rotation/rotation.h"
#include "host/util/csv_table.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

Eigen::Vector3d PositionM(const CsvTable& t, std::size_t row) {
  return 1e-3 * Eigen::Vector3d(t.Number(row, t.Column("x_mm")), t.Number(row, t.Column("y_mm")),
                                t.Number(row, t.Column("z_mm")));
}

// A whole number in [0, max] (frame indices, times, counts): a cast of anything else is undefined.
double Count(const CsvTable& t, std::size_t row, const char* column, double max) {
  const double v = t.Number(row, t.Column(column));
  if (!(v >= 0.0 && v <= max) || v != std::floor(v))
    throw UserError(t.source() + ":" + std::to_string(t.Line(row)) + ": column '" + column +
                    "': expected a whole number from 0 to " + std::to_string(static_cast<unsigned long long>(max)) +
                    ", got '" + OneLine(t.Cell(row, t.Column(column))) + "'");
  return v;
}

ViewPose PoseOfRow(const CsvTable& t, std::size_t row) {
  ViewPose p;
  p.frame_set = static_cast<std::uint32_t>(Count(t, row, "frame", 4294967295.0));
  p.t_ns = static_cast<std::uint64_t>(Count(t, row, "t_ns", 9.0e18));
  p.status = t.Cell(row, t.Column("status"));
  if (p.status != "fix" && p.status != "degraded" && p.status != "lost")
    throw UserError(t.source() + ":" + std::to_string(t.Line(row)) + ": column 'status': expected fix, degraded or lost, got '" +
                    OneLine(p.status) + "'");
  p.reason = t.HasColumn("reason") ? t.Cell(row, t.Column("reason")) : std::string("none");
  p.num_beacons = static_cast<int>(Count(t, row, "n_beacons", limits::kMaxBeacons));
  p.rms_px = t.Number(row, t.Column("rms_px"));
  p.r_w_wb = PositionM(t, row);
  p.euler_deg = Eigen::Vector3d(t.Number(row, t.Column("roll_deg")), t.Number(row, t.Column("pitch_deg")),
                                t.Number(row, t.Column("yaw_deg")));
  p.has_pose = p.status != "lost" && p.r_w_wb.allFinite() && p.euler_deg.allFinite();
  if (p.has_pose) {
    const EulerAngles e{DegToRad(p.euler_deg.x()), DegToRad(p.euler_deg.y()), DegToRad(p.euler_deg.z())};
    p.C_w_b = EulerToMatrix(e).transpose();  // the columns are of C_b_w
  }
  return p;
}

}  // namespace

std::vector<ViewPose> ReadPosesCsv(const std::filesystem::path& path) {
  const CsvTable t = CsvTable::Read(path);
  for (const char* c : {"frame", "t_ns", "status", "x_mm", "y_mm", "z_mm", "roll_deg", "pitch_deg", "yaw_deg",
                        "n_beacons", "rms_px"})
    t.Column(c);  // each missing column is named before any row is read
  std::vector<ViewPose> poses;
  poses.reserve(t.size());
  for (std::size_t row = 0; row < t.size(); ++row) poses.push_back(PoseOfRow(t, row));
  if (poses.empty()) throw UserError(path.string() + ": no rows (a poses CSV of at least one frame set)");
  return poses;
}

std::vector<Eigen::Vector3d> ReadTruthTrail(const std::filesystem::path& path) {
  const CsvTable t = CsvTable::Read(path);
  std::vector<Eigen::Vector3d> r;
  r.reserve(t.size());
  for (std::size_t row = 0; row < t.size(); ++row) {
    const Eigen::Vector3d p = PositionM(t, row);
    if (!p.allFinite())
      throw UserError(t.source() + ":" + std::to_string(t.Line(row)) + ": the position is not finite");
    r.push_back(p);
  }
  return r;
}

double PlaybackDelayS(const std::vector<ViewPose>& poses, std::size_t i, double speed) {
  if (i == 0 || i >= poses.size() || !(speed > 0.0)) return 0.0;
  const double step_s = (static_cast<double>(poses[i].t_ns) - static_cast<double>(poses[i - 1].t_ns)) * 1e-9;
  return std::clamp(step_s / speed, 0.0, 1.0);
}

}  // namespace mfns::host
