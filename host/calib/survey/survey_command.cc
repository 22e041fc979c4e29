#include "host/calib/survey/survey_command.h"

#include "host/calib/survey/survey_report.h"
#include "host/calib/survey/turntable_placement_yaml.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <ostream>
#include <string>
#include <utility>

#include "common/blob/param_blob.h"
#include "common/rotation/rotation.h"
#include "firmware/app/navd/nav_loop.h"
#include "firmware/drivers/replay/replay_source.h"
#include "host/rigio/rig_yaml.h"
#include "host/util/atomic_file.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

// The fix's identities with their centroids, from the loop's last frame set.
SurveyFrameSet FixOf(const fw::NavLoop& loop, const fw::PoseRecord& rec) {
  SurveyFrameSet s;
  s.t_ns = rec.t_capture_ns;
  const fw::NavOutput& nav = loop.last_output();
  s.pose = nav.pose;
  const fw::BlobObs* obs = loop.observations();
  for (int i = 0; i < nav.num_matches; ++i) {
    const fw::Match& m = nav.matches[static_cast<std::size_t>(i)];
    if (m.blob < 0 || m.blob >= loop.num_observations()) continue;  // (cannot happen: the navigator's own)
    s.observations.push_back({m.camera, m.beacon, obs[m.blob].uv_px});
  }
  return s;
}

std::uint64_t NowSeconds() {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch()).count());
}

RecordingOptions RecordingOptionsOf(const SurveyCommandOptions& o) {
  RecordingOptions r;
  r.sigma_px = o.sigma_px;
  if (o.initial_pose.size() == 6) {
    r.has_initial_pose = true;
    r.initial_pose.r_w_wb = Eigen::Vector3d(o.initial_pose[0], o.initial_pose[1], o.initial_pose[2]) * 1e-3;
    // As mfns-navd's --initial-pose: the poses CSV's angles are the Euler angles of C_b_w.
    r.initial_pose.C_w_b =
        EulerToMatrix(EulerAngles{DegToRad(o.initial_pose[3]), DegToRad(o.initial_pose[4]), DegToRad(o.initial_pose[5])})
            .transpose();
  }
  if (o.initial_sigma.size() == 2) {
    r.initial_sigma_m = o.initial_sigma[0] * 1e-3;
    r.initial_sigma_rad = DegToRad(o.initial_sigma[1]);
  }
  return r;
}

// The refined cameras' mountings; where the rig carries calibration sigmas, a refined camera's
// Euler-angle and position sigmas from its covariance (intrinsics' sigmas as given).
void RefinedCameras(const SurveyResult& r, Rig* out) {
  for (std::size_t k = 0; k < r.cameras.size(); ++k) {
    const SurveyCamera& c = r.cameras[k];
    if (!c.refined) continue;
    out->cameras[k].C_k_b = c.C_k_b;
    out->cameras[k].r_b_bk = c.r_b_bk;
    if (!out->has_sigma) continue;
    const Eigen::Matrix3d J_inv = EulerToRotationJacobian(c.C_k_b).inverse();
    out->sigma[k].euler = (J_inv * c.covariance.topLeftCorner<3, 3>() * J_inv.transpose()).diagonal().cwiseSqrt();
    out->sigma[k].r_b_bk = c.covariance.bottomRightCorner<3, 3>().diagonal().cwiseSqrt();
  }
}

// The input rig with the refined map and each beacon's 1-sigma (its largest per-axis one: the
// rig file and the blob hold one number per beacon); beacon_sigma the largest of them; and the
// refined cameras (RefinedCameras).
Rig RefinedRig(const Rig& in, const SurveyResult& r, const std::string& rig_id) {
  Rig out = in;
  RefinedCameras(r, &out);
  out.has_beacon_sigmas = true;
  out.beacon_sigma = 0.0;
  for (std::size_t b = 0; b < r.beacons.size(); ++b) {
    out.beacons_w[b] = r.beacons[b].refined_w;
    out.beacon_sigmas[b] = r.beacons[b].Sigma().maxCoeff();
    out.beacon_sigma = std::max(out.beacon_sigma, out.beacon_sigmas[b]);
  }
  if (!rig_id.empty()) {
    if (rig_id.size() > limits::kMaxRigIdChars) throw UserError("--rig-id: longer than " + std::to_string(limits::kMaxRigIdChars) + " characters");
    out.rig_id.fill('\0');
    std::copy(rig_id.begin(), rig_id.end(), out.rig_id.begin());
  }
  const RigStatus s = ValidateRig(out);
  if (s != RigStatus::kOk) throw UserError(std::string("survey: the refined rig is not valid: ") + ToString(s));
  return out;
}

// The recordings' surveyed turntable placements, one per pivot group: from the files
// (--turntable-placement, "none" for a recording without one), or the first recording's from
// --turntable-centre-mm, --turntable-mount-mm and --turntable-axis (the centre's sigma defaults
// to the map's: the same instrument); none without either.
std::vector<TurntablePlacement> TurntablePlacementsOf(const SurveyCommandOptions& o, const Rig& rig) {
  std::vector<TurntablePlacement> out;
  for (const std::string& file : o.turntable_placements)
    out.push_back(file == "none" ? TurntablePlacement{} : ReadTurntablePlacementYaml(file));
  if (!o.turntable_placements.empty()) return out;
  if (o.turntable_centre_mm.empty() && o.turntable_axis.empty() && o.turntable_mount_mm.empty()) return {};
  const auto mm = [](const std::vector<double>& v) { return Eigen::Vector3d(v[0], v[1], v[2]) * 1e-3; };
  TurntablePlacement t;
  t.has_centre = o.turntable_centre_mm.size() == 3;
  if (t.has_centre) {
    t.centre_w = mm(o.turntable_centre_mm);
    t.centre_sigma_m = o.turntable_centre_sigma_set ? o.turntable_centre_sigma_mm * 1e-3 : rig.beacon_sigma;
  }
  t.has_centre_b = o.turntable_mount_mm.size() == 3;
  if (t.has_centre_b) {
    t.centre_b = mm(o.turntable_mount_mm);
    t.centre_b_sigma_m = o.turntable_mount_sigma_mm * 1e-3;
  }
  t.has_axis = o.turntable_axis.size() == 3;
  if (t.has_axis) {
    t.axis_w = Eigen::Vector3d(o.turntable_axis[0], o.turntable_axis[1], o.turntable_axis[2]).normalized();
    t.axis_sigma_rad = DegToRad(o.turntable_axis_sigma_deg);
  }
  return {t};
}

std::vector<std::uint8_t> BlobOf(const Rig& rig, std::uint64_t generation) {
  std::vector<std::uint8_t> bytes(limits::kMaxBlobBytes);
  std::size_t written = 0;
  const BlobStatus s = EncodeParamBlob(rig, generation, bytes, &written);
  if (s != BlobStatus::kOk) throw UserError(std::string("survey: cannot encode the refined rig: ") + ToString(s));
  bytes.resize(written);
  return bytes;
}

// The refined cameras' (with refine_cameras) and the pivot groups' lines of the log.
void LogCamerasAndPivots(const Rig& rig, const SurveyResult& r, bool refine_cameras, std::ostream& log) {
  for (std::size_t k = 0; k < r.cameras.size(); ++k) {
    const SurveyCamera& c = r.cameras[k];
    if (!refine_cameras) break;
    char line[256];
    std::snprintf(line, sizeof line, "survey: camera %s: %s", rig.cameras[k].name.data(),
                  c.refined ? "" : (c.observations > 0 ? "held (it defines the body frame)" : "held (never seen)"));
    log << line;
    if (c.refined) {
      const Eigen::Matrix<double, 6, 1> sg = c.covariance.diagonal().cwiseSqrt();
      std::snprintf(line, sizeof line, "rotation changed %.4f deg (1-sigma %.4f), position %.3f mm (1-sigma %.3f)",
                    RadToDeg(c.rotation_change_rad.norm()), RadToDeg(sg.head<3>().norm()),
                    1e3 * c.translation_change_m.norm(), 1e3 * sg.tail<3>().norm());
      log << line;
    }
    log << std::endl;
  }
  for (std::size_t g = 0; g < r.pivots.size(); ++g) {
    const SurveyPivot& p = r.pivots[g];
    char line[256];
    std::snprintf(line, sizeof line, "survey: recording %zu turns about p_w = (%.1f, %.1f, %.1f) mm, p_b = (%.1f, %.1f, %.1f) mm",
                  g + 1, 1e3 * p.p_w.x(), 1e3 * p.p_w.y(), 1e3 * p.p_w.z(), 1e3 * p.p_b.x(), 1e3 * p.p_b.y(), 1e3 * p.p_b.z());
    log << line;
    if (p.has_axis) {
      std::snprintf(line, sizeof line, ", axis (%.6f, %.6f, %.6f) in the world", p.axis_w.x(), p.axis_w.y(), p.axis_w.z());
      log << line;
    }
    log << std::endl;
  }
}

}  // namespace

std::vector<SurveyFrameSet> PoseRecording(const Rig& rig, const std::filesystem::path& dir, const RecordingOptions& o,
                                          RecordingSummary* summary) {
  const std::string dir_s = dir.string();
  fw::ReplaySource source(fw::ReplayConfigFromRig(rig, dir_s.c_str()));
  const fw::SourceStatus ss = source.Start();
  if (ss != fw::SourceStatus::kOk)
    throw UserError(dir_s + ": cannot replay: " + fw::ToString(ss) +
                    (source.problem()[0] != '\0' ? std::string(" (") + source.problem() + ")" : std::string()));
  auto loop = std::make_unique<fw::NavLoop>(rig, &source, nullptr, nullptr, nullptr);
  fw::NavLoopConfig config;
  config.sigma_px = o.sigma_px;
  config.has_initial_pose = o.has_initial_pose;
  config.initial_pose = o.initial_pose;
  config.initial_sigma_m = o.initial_sigma_m;
  config.initial_sigma_rad = o.initial_sigma_rad;
  const char* why = nullptr;
  if (!loop->Configure(config, &why)) throw UserError(dir_s + ": mfns-navd's loop refuses the rig: " + (why ? why : "?"));
  std::vector<SurveyFrameSet> sets;
  RecordingSummary sum;
  fw::PoseRecord rec;
  while (loop->Step(&rec) == fw::StepStatus::kOk) {
    ++sum.frame_sets;
    if (rec.status != fw::NavStatus::kFix) continue;
    ++sum.fixes;
    sets.push_back(FixOf(*loop, rec));
  }
  if (summary != nullptr) *summary = sum;
  return sets;
}

std::string FormatSurveyCsv(const SurveyResult& r, double moved_sigmas) {
  std::string out =
      "beacon,surveyed_x_mm,surveyed_y_mm,surveyed_z_mm,refined_x_mm,refined_y_mm,refined_z_mm,sigma_x_mm,sigma_y_mm,"
      "sigma_z_mm,shift_mm,shift_sigmas,observations,frame_sets,rms_px,moved,seen\n";
  char line[512];
  for (std::size_t b = 0; b < r.beacons.size(); ++b) {
    const SurveyBeacon& s = r.beacons[b];
    const Eigen::Vector3d p = s.surveyed_w * 1e3, q = s.refined_w * 1e3, sg = s.Sigma() * 1e3;
    std::snprintf(line, sizeof line, "%zu,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.2f,%d,%d,%.4f,%d,%d\n", b,
                  p.x(), p.y(), p.z(), q.x(), q.y(), q.z(), sg.x(), sg.y(), sg.z(), (q - p).norm(), s.shift_sigmas,
                  s.observations, s.frame_sets, s.rms_px, s.shift_sigmas > moved_sigmas ? 1 : 0,
                  s.observations > 0 ? 1 : 0);
    out += line;
  }
  return out;
}

SurveyResult RunSurveyCommand(const SurveyCommandOptions& o, std::ostream& log) {
  ValidateSurveyCommand(o);
  const Rig rig = ReadRigYaml(o.rig_path);
  if (!(rig.beacon_sigma > 0.0))
    throw UserError(o.rig_path + ": beacon_sigma_mm: the surveyed map's 1-sigma is needed (the survey's prior)");
  // (Read before the recordings are posed: a bad placement file fails at once.)
  std::vector<TurntablePlacement> placements = TurntablePlacementsOf(o, rig);
  const RecordingOptions ro = RecordingOptionsOf(o);
  std::vector<SurveyFrameSet> sets;
  SurveyReportContext ctx;
  ctx.rig_path = o.rig_path;
  for (const std::string& dir : o.recordings) {
    RecordingSummary sum;
    std::vector<SurveyFrameSet> s = PoseRecording(rig, dir, ro, &sum);
    if (o.turntable)
      for (SurveyFrameSet& f : s) f.pivot_group = static_cast<int>(ctx.recordings.size());
    ctx.recordings.push_back(dir + ": " + std::to_string(sum.frame_sets) + " frame sets, " + std::to_string(sum.fixes) +
                             " fixes");
    log << "survey: " << ctx.recordings.back() << std::endl;
    // A recording with no fix has no pivot group to place: its placement is left out (and a last
    // one dropped, the adjustment refusing a placement beyond its groups), said on the log.
    const std::size_t index = ctx.recordings.size() - 1;
    if (s.empty() && index < placements.size() && placements[index].Any()) {
      placements[index] = TurntablePlacement{};
      log << "survey: " << dir << ": no fix, its turntable placement is not used" << std::endl;
    }
    sets.insert(sets.end(), std::make_move_iterator(s.begin()), std::make_move_iterator(s.end()));
  }
  if (sets.empty()) throw UserError("survey: no frame set of the recordings was posed as fix: nothing to refine from");
  int groups = 0;
  for (const SurveyFrameSet& f : sets) groups = std::max(groups, f.pivot_group + 1);
  if (placements.size() > static_cast<std::size_t>(groups)) placements.resize(static_cast<std::size_t>(groups));
  SurveyOptions so;
  so.start_sigma_px = o.sigma_px;
  so.threads = o.jobs;
  so.refine_cameras = o.refine_cameras;
  so.turntables = std::move(placements);
  const SurveyResult r = AdjustMap(rig, sets, so, &log);
  const Rig out = RefinedRig(rig, r, o.rig_id);
  // Everything is encoded before anything is written: a failure leaves DIR as it was.
  const std::string rig_text = FormatRigYaml(out);
  const std::vector<std::uint8_t> blob = BlobOf(out, o.generation_set ? o.generation : NowSeconds());
  const std::string csv = FormatSurveyCsv(r, so.moved_sigmas);
  ctx.moved_sigmas = so.moved_sigmas;
  ctx.command_line = o.command_line;
  const std::string html = SurveyReportHtml(rig, r, ctx);
  const std::filesystem::path dir(o.out_dir);
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw UserError(o.out_dir + ": cannot create: " + ec.message());
  WriteFileAtomic(dir / "survey.csv", csv);
  WriteFileAtomic(dir / "report.html", html);
  WriteFileAtomic(dir / "calibration.bin", blob);
  WriteFileAtomic(dir / "rig.yaml", rig_text);
  LogCamerasAndPivots(rig, r, so.refine_cameras, log);
  int seen = 0, moved = 0;
  for (const SurveyBeacon& b : r.beacons) {
    seen += b.observations > 0 ? 1 : 0;
    moved += b.moved ? 1 : 0;
  }
  log << "survey: " << sets.size() << " frame sets, " << r.observations << " observations, " << seen << " of "
      << r.beacons.size() << " beacons seen, centroid sigma " << r.sigma_px << " px, residual RMS " << r.rms_px
      << " px, " << r.outliers << " outliers, " << moved << " beacons moved?; wrote " << o.out_dir
      << "/{rig.yaml,calibration.bin,survey.csv,report.html}" << std::endl;
  return r;
}

}  // namespace mfns::host
