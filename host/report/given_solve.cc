#include "host/report/given_solve.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <vector>

#include "common/camera/camera.h"
#include "common/rotation/rotation.h"
#include "firmware/modules/solve/solve.h"
#include "host/util/csv_table.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

struct FrameObs {
  std::vector<fw::BlobObs> blobs;
  std::vector<fw::Match> matches;
};

int CameraIndex(const Rig& rig, const std::string& name) {
  for (int i = 0; i < rig.num_cameras; ++i)
    if (name == rig.cameras[static_cast<std::size_t>(i)].name.data()) return i;
  return -1;
}

std::map<long, FrameObs> ReadBlobs(const std::filesystem::path& path, const Rig& rig, bool geometric) {
  const CsvTable t = CsvTable::Read(path);
  const int frame_col = t.Column("frame"), cam_col = t.Column("camera"), beacon_col = t.Column("beacon");
  const int u_col = t.Column(geometric ? "u_geom_px" : "u_px"), v_col = t.Column(geometric ? "v_geom_px" : "v_px");
  std::map<long, FrameObs> frames;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const std::string where = t.source() + ":" + std::to_string(t.Line(i)) + ": ";
    const int cam = CameraIndex(rig, t.Cell(i, cam_col));
    if (cam < 0) throw UserError(where + "camera '" + t.Cell(i, cam_col) + "' is not in the rig");
    const long beacon = std::lround(t.Number(i, beacon_col));
    if (beacon < 0 || beacon >= rig.num_beacons)
      throw UserError(where + "beacon " + std::to_string(beacon) + " is not in the rig's map of " +
                      std::to_string(rig.num_beacons));
    FrameObs& f = frames[std::lround(t.Number(i, frame_col))];
    if (static_cast<int>(f.matches.size()) >= limits::kMaxMatches) continue;
    fw::BlobObs b;
    b.camera = cam;
    b.uv_px = Eigen::Vector2d(t.Number(i, u_col), t.Number(i, v_col));
    if (Unproject(rig.cameras[static_cast<std::size_t>(cam)].intrinsics, b.uv_px, &b.x_n) != UnprojectStatus::kOk)
      continue;
    f.matches.push_back({static_cast<int>(f.blobs.size()), static_cast<int>(beacon), cam});
    f.blobs.push_back(b);
  }
  return frames;
}

fw::SolveOptions NewtonOptions(double sigma_px) {
  fw::SolveOptions o;
  o.loss = fw::RobustLoss::kNone;
  o.initial_lambda = 0.0;  // Gauss-Newton, as the paper's Newton iteration
  o.outlier_threshold_px = 0.0;
  o.max_outlier_rounds = 0;
  o.sigma_px = sigma_px;
  return o;
}

bool Solve(const Rig& rig, const FrameObs& f, const BodyPose& initial, const fw::SolveOptions& o, fw::SolveResult* r) {
  const fw::SolveStatus s = fw::SolvePose(rig, f.blobs.data(), static_cast<int>(f.blobs.size()), f.matches.data(),
                                          static_cast<int>(f.matches.size()), initial, o, r);
  return s == fw::SolveStatus::kOk;
}

}  // namespace

GivenSolveSummary SolveGivenCorrespondences(const std::filesystem::path& sim_dir, const Rig& rig,
                                            const GivenSolveOptions& options, const std::filesystem::path& out_csv) {
  const CsvTable truth = CsvTable::Read(sim_dir / "truth.csv");
  const std::map<long, FrameObs> frames = ReadBlobs(sim_dir / "blobs.csv", rig, options.use_geometric);
  const fw::SolveOptions opt = NewtonOptions(options.sigma_px);
  const int frame_col = truth.Column("frame"), t_col = truth.Column("t_ns"), yaw_col = truth.Column("yaw_deg");

  std::string out = "frame,t_ns,status,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg,n_beacons,rms_px\n";
  GivenSolveSummary sum;
  bool have_last = false;
  BodyPose last;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const long frame = std::lround(truth.Number(i, frame_col));
    ++sum.frames;
    const auto it = frames.find(frame);
    fw::SolveResult best;
    bool ok = false;
    if (it != frames.end() && it->second.matches.size() >= 3) {
      // Start from the last pose; without one from the turntable's reading (the true yaw of
      // truth.csv, known to 8 arcsec on the real table), then from yaws every 30 deg.
      BodyPose start;
      start.C_w_b = EulerToMatrix(EulerAngles{0.0, 0.0, DegToRad(truth.Number(i, yaw_col))}).transpose();
      ok = Solve(rig, it->second, have_last ? last : start, opt, &best);
      if (!ok && have_last) ok = Solve(rig, it->second, start, opt, &best);
      for (int k = 0; !ok && k < 12; ++k) {
        BodyPose init;
        init.C_w_b = EulerToMatrix(EulerAngles{0.0, 0.0, DegToRad(30.0 * k)}).transpose();
        ok = Solve(rig, it->second, init, opt, &best);
      }
    }
    char line[256];
    if (ok) {
      ++sum.fixes;
      last = best.pose;
      have_last = true;
      const Eigen::Vector3d p = best.pose.r_w_wb * 1e3;
      const EulerAngles e = MatrixToEuler(best.pose.C_w_b.transpose());
      std::snprintf(line, sizeof(line), "%ld,%s,fix,%.4f,%.4f,%.4f,%.6f,%.6f,%.6f,%d,%.4f\n", frame,
                    truth.Cell(i, t_col).c_str(), p.x(), p.y(), p.z(), RadToDeg(e.phi), RadToDeg(e.theta),
                    RadToDeg(e.psi), best.num_beacons, best.rms_px);
    } else {
      ++sum.lost;
      have_last = false;
      const int n = it == frames.end() ? 0 : static_cast<int>(it->second.matches.size());
      std::snprintf(line, sizeof(line), "%ld,%s,lost,nan,nan,nan,nan,nan,nan,%d,nan\n", frame,
                    truth.Cell(i, t_col).c_str(), n);
    }
    out += line;
  }
  WriteFileAtomic(out_csv, out);
  return sum;
}

}  // namespace mfns::host
