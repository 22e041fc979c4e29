#include "host/calib/app/calib_commands.h"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <map>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "common/rotation/rotation.h"
#include "host/calib/report/compare.h"
#include "host/calib/report/outputs.h"
#include "host/core/image.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

std::uint64_t NowSeconds() {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch()).count());
}

cv::Mat ReadAnyImage(const std::string& path) {
  if (std::filesystem::path(path).extension() == ".pgm") return ReadPgm(path);
  cv::Mat m = cv::imread(path, cv::IMREAD_ANYDEPTH | cv::IMREAD_GRAYSCALE);
  if (m.empty()) throw PgmError(path + ": cannot read the image");
  return m;
}

void PrintSummary(const RigCalibration& rig, const CalibDataset& ds, std::ostream& log) {
  std::ostringstream o;
  o.precision(6);
  o << "rig (" << rig.method << "): RMS " << rig.rms_px << " px\n";
  for (const CameraResult& c : rig.cameras) {
    const EulerAngles e = MatrixToEuler(c.C_k_b);
    o << "  camera " << c.name << ": alpha (" << c.intrinsics.alpha_x << ", " << c.intrinsics.alpha_y << ") pp ("
      << c.intrinsics.u0 << ", " << c.intrinsics.v0 << ") euler_deg (" << RadToDeg(e.phi) << ", " << RadToDeg(e.theta)
      << ", " << RadToDeg(e.psi) << ") r_b_bk_mm (" << c.r_b_bk.x() * 1e3 << ", " << c.r_b_bk.y() * 1e3 << ", "
      << c.r_b_bk.z() * 1e3 << ") RMS " << c.rms_px << " px\n";
  }
  if (ds.truth.has_rig) {
    const RigErrors e = CompareRig(rig, ds.truth.rig, ds.truth.has_mount ? &ds.truth.mount : nullptr);
    o << "against truth:";
    for (const CameraError& c : e.cameras) o << " " << c.name << " " << c.rotation_deg << " deg " << c.position_mm << " mm;";
    int within = 0, total = 0;
    for (const ParamError& p : e.params)
      if (p.sigma > 0) {
        ++total;
        within += std::abs(p.error) <= 3 * p.sigma ? 1 : 0;
      }
    if (total > 0) o << " " << within << "/" << total << " parameters within 3 sigma";
    o << "\n";
  }
  log << o.str();
}

// --compare: every method on the same corners, errors against the truth side by side.
void Compare(const CalibInput& in, const IntrinsicsStage& stage, RigOptions ro, const RigCalibration& main_result,
             const CalibDataset& ds, const std::string& out_dir, std::ostream& log) {
  if (!ds.truth.has_rig) throw UserError("--compare needs the dataset's truth-rig.yaml");
  std::ostringstream csv, table;
  csv.precision(8);
  table.precision(4);
  csv << "method,camera,rotation_error_deg,position_error_mm,within_3_sigma,parameters\n";
  table << "compare (error against truth: C_k_b deg / r_b_bk mm):\n";
  ro.progress = nullptr;
  const RigMethod chosen = ro.method;
  for (RigMethod m : {RigMethod::kMl, RigMethod::kPaper, RigMethod::kOpenCvHandEye}) {
    ro.method = m;
    RigCalibration r;
    try {
      r = m == chosen ? main_result : SolveRig(in, stage, ro);
    } catch (const std::exception& e) {  // a comparison that fails (e.g. OpenCV's on too few poses) is reported
      std::string what = e.what();
      std::replace(what.begin(), what.end(), '\n', ' ');
      table << "  " << ToString(m) << ": failed: " << what << "\n";
      continue;
    }
    const RigErrors e = CompareRig(r, ds.truth.rig, ds.truth.has_mount ? &ds.truth.mount : nullptr);
    int within = 0, total = 0;
    for (const ParamError& p : e.params) {
      ++total;
      within += p.sigma > 0 && std::abs(p.error) <= 3 * p.sigma ? 1 : 0;
    }
    table << "  " << ToString(m) << ":";
    for (const CameraError& c : e.cameras) {
      csv << ToString(m) << "," << c.name << "," << c.rotation_deg << "," << c.position_mm << "," << within << ","
          << total << "\n";
      table << " " << c.name << " " << c.rotation_deg << " / " << c.position_mm << ";";
    }
    table << "\n";
  }
  log << table.str();
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  WriteFileAtomic(std::filesystem::path(out_dir) / "compare.csv", csv.str());
}

}  // namespace

CalibInput CornersFromCsv(const CalibDataset& ds, const std::string& path) {
  std::map<std::string, std::vector<CornerRow>> by_image;  // "camera/image"
  for (CornerRow& row : ParseCornersCsv(ReadFile(path), path, static_cast<int>(TargetPoints(ds.target).size())))
    by_image[row.camera + "/" + row.image].push_back(std::move(row));
  CalibInput in;
  in.target_points = TargetPoints(ds.target);
  for (const std::string& name : ds.cameras) in.cameras.push_back({name, 0, 0});
  const auto camera_of = [&](const DatasetImage& im) {
    return static_cast<std::size_t>(std::find(ds.cameras.begin(), ds.cameras.end(), im.camera) - ds.cameras.begin());
  };
  for (const DatasetImage& im : ds.images) {  // each camera's image size from its first readable image
    CameraInfo& cam = in.cameras[camera_of(im)];
    if (cam.width != 0) continue;
    try {
      const cv::Mat m = ReadPgm(im.path.string());
      cam.width = m.cols;
      cam.height = m.rows;
    } catch (const PgmError&) {
    }
  }
  for (const CameraInfo& c : in.cameras)
    if (c.width == 0) throw UserError("camera " + c.name + ": no readable image to take its size from");
  for (const DatasetImage& im : ds.images) {
    const std::size_t k = camera_of(im);
    const CameraInfo& cam = in.cameras[k];
    auto it = by_image.find(im.camera + "/" + im.image);
    if (it == by_image.end()) {
      in.skipped.push_back({im.camera, im.image, "no corners in " + path});
      continue;
    }
    ViewObservation v;
    v.camera = static_cast<int>(k);
    v.image = im.image;
    v.kind = im.kind;
    v.main_cmd = im.main_cmd;
    v.aux_cmd = im.aux_cmd;
    for (const CornerRow& row : it->second) {
      // Within the image or near it: a finite but absurd coordinate (1e300) must not reach the
      // solvers (it aborted Ceres).
      const double size[2] = {static_cast<double>(cam.width), static_cast<double>(cam.height)};
      for (int a = 0; a < 2; ++a) {
        const double lo = -0.5 - kCornerMarginPx, hi = size[a] - 0.5 + kCornerMarginPx;
        if (!(row.corner.uv[a] >= lo && row.corner.uv[a] <= hi)) {
          std::ostringstream msg;
          msg << path << ":" << row.line << ": " << (a == 0 ? "u_px" : "v_px") << ": " << row.corner.uv[a]
              << " is outside the " << cam.width << "x" << cam.height << " image of camera " << cam.name << " (" << lo
              << ".." << hi << ")";
          throw UserError(msg.str());
        }
      }
      v.corners.push_back(row.corner);
    }
    std::sort(v.corners.begin(), v.corners.end(), [](const CornerObs& a, const CornerObs& b) { return a.id < b.id; });
    in.views.push_back(std::move(v));
  }
  return in;
}

std::string FormatCornersCsv(const CalibInput& in) {
  std::ostringstream o;
  o.precision(10);
  o << "camera,image,corner,u_px,v_px\n";
  for (const ViewObservation& v : in.views)
    for (const CornerObs& c : v.corners)
      o << in.cameras[static_cast<std::size_t>(v.camera)].name << "," << v.image << "," << c.id << "," << c.uv.x() << ","
        << c.uv.y() << "\n";
  return o.str();
}

RigCalibration RunRigCommand(const RigCommandOptions& o, std::ostream& log) {
  RigOptions ro;
  ro.method = ValidateRigCommand(o);
  ro.fix_k3 = !o.free_k3;
  ro.huber_px = o.huber_px;
  ro.reference_camera = o.reference_camera;
  ro.paper_rows_only = !o.all_a10_rows;
  ro.covariance = !o.no_covariance;
  ro.progress = &log;
  const CalibDataset ds = ReadCalibDataset(o.dataset);
  log << "mfns-calib rig: " << ds.images.size() << " images of " << ds.cameras.size() << " cameras in " << o.dataset
      << ", method " << ToString(ro.method) << "\n";
  DetectOptions det;
  det.corner_refine = RefineCorners(o.refine_corners, o.refine_corners_given, o.fast_detect);
  det.sb_accuracy = SbAccuracy(o.fast_detect, det.corner_refine);
  det.min_corners = ro.min_corners;
  CalibInput in = o.corners_csv.empty() ? DetectDataset(ds, det, o.jobs, &log) : CornersFromCsv(ds, o.corners_csv);
  if (!o.corners_csv.empty()) log << "corners from " << o.corners_csv << " (no detection)\n";
  const double angle_arcsec =
      !o.angle_sigma_set && ds.truth.angle_sigma_arcsec > 0 ? ds.truth.angle_sigma_arcsec : o.angle_sigma_arcsec;
  in.angle_sigma = DegToRad(angle_arcsec / 3600.0);
  log << "turntable angle prior: " << angle_arcsec << " arcsec 1-sigma\n";
  std::string mount_note;
  if (!o.mount_mm.empty()) {
    in.r_p_pb = Eigen::Vector3d(o.mount_mm[0], o.mount_mm[1], o.mount_mm[2]) * 1e-3;
    mount_note = "mount r_p_pb from --mount-mm";
  } else if (ds.truth.has_mount) {
    in.C_p_b = ds.truth.mount.C_p_b;
    in.r_p_pb = ds.truth.mount.r_p_pb;
    mount_note = "mount C_p_b, r_p_pb from the dataset's truth.yaml (the measured mount)";
  } else {
    mount_note = "mount r_p_pb = 0: body origin at Ot (no --mount-mm, no truth.yaml)";
  }
  log << mount_note << "\n";
  const IntrinsicsStage stage = PrepareViews(&in, ro);
  if (!o.write_corners_csv.empty()) WriteFileAtomic(o.write_corners_csv, FormatCornersCsv(in));
  log << in.skipped.size() << " images skipped\n";
  for (const SkippedImage& s : in.skipped) log << "  skipped " << s.camera << "/" << s.image << ": " << s.reason << "\n";
  RigCalibration rig = SolveRig(in, stage, ro);
  rig.notes.insert(rig.notes.begin(), mount_note);
  if (o.compare) Compare(in, stage, ro, rig, ds, o.out_dir, log);
  CrossValidation cv;
  if (o.cross_validate) {
    cv = CrossValidateRig(in, ro);
    log << FormatCrossValidation(cv);
  }

  ReportContext ctx;
  ctx.dataset = o.dataset;
  ctx.command_line = "mfns-calib rig " + o.dataset + " --out " + o.out_dir + " --method " + o.method +
                     (o.cross_validate ? " --cross-validate" : "");
  ctx.rig_id = !o.rig_id.empty() ? o.rig_id : ds.truth.has_rig ? std::string(ds.truth.rig.rig_id.data()) : "mfns-calibrated";
  ctx.generation = o.generation_set ? o.generation : NowSeconds();
  ctx.truth_rig = ds.truth.has_rig ? &ds.truth.rig : nullptr;
  ctx.truth_mount = ds.truth.has_mount ? &ds.truth.mount : nullptr;
  ctx.cross_validation = o.cross_validate ? &cv : nullptr;
  WriteRigOutputs(o.out_dir, rig, in, ctx);
  PrintSummary(rig, ds, log);
  log << "mfns-calib rig: wrote rig.yaml, calibration.bin, camchain.yaml, camera-*.yaml, report.html in " << o.out_dir
      << " (" << in.skipped.size() << " images skipped)\n";
  return rig;
}

ZhangResult RunIntrinsicsCommand(const IntrinsicsCommandOptions& o, std::ostream& log) {
  const CalibrationTarget target = ValidateIntrinsicsCommand(o);
  const std::vector<Eigen::Vector3d> pts = TargetPoints(target);
  DetectOptions det;
  det.corner_refine = RefineCorners(o.refine_corners, o.refine_corners_given, o.fast_detect);
  det.sb_accuracy = SbAccuracy(o.fast_detect, det.corner_refine);
  CornerRefineStats refine;
  std::vector<std::vector<CornerObs>> views;
  std::vector<std::string> used;
  std::vector<SkippedImage> skipped;
  int width = 0, height = 0;
  for (const std::string& path : o.images) {
    cv::Mat image;
    try {
      image = ReadAnyImage(path);
    } catch (const PgmError& e) {
      skipped.push_back({o.camera, path, std::string("unreadable: ") + e.what()});
      log << "intrinsics: " << path << " skipped: unreadable\n";
      continue;
    }
    if (width == 0) {
      width = image.cols;
      height = image.rows;
    }
    DetectResult d;
    if (image.cols != width || image.rows != height)
      d.reason = "size differs from the first image's";
    else
      d = DetectTarget(image, target, det);
    refine.Add(d.refine_stats);
    if (!d.ok) {
      skipped.push_back({o.camera, path, d.reason});
      log << "intrinsics: " << path << " skipped: " << d.reason << "\n";
      continue;
    }
    log << "intrinsics: " << path << ": " << d.corners.size() << " corners\n";
    views.push_back(std::move(d.corners));
    used.push_back(path);
  }
  if (det.corner_refine) log << "corner refinement: " << ToString(refine) << "\n";
  ZhangOptions zo;
  zo.fix_k3 = !o.free_k3;
  const ZhangResult z = CalibrateZhang(views, pts, width, height, zo);
  CameraResult c;
  c.name = o.camera;
  c.intrinsics = z.camera;
  c.sigma_intrinsics = z.sigma;
  c.rms_px = z.rms_px;
  std::vector<double> rms;
  for (const ZhangView& v : z.views) rms.push_back(v.rms_px);
  std::error_code ec;
  std::filesystem::create_directories(o.out_dir, ec);
  if (!std::filesystem::is_directory(o.out_dir)) throw UserError(o.out_dir + ": cannot create the output directory");
  const std::filesystem::path yaml = std::filesystem::path(o.out_dir) / ("camera-" + o.camera + ".yaml");
  WriteFileAtomic(yaml, FormatOpenCvCameraYaml(c, used, rms, false));
  std::ostringstream r;
  r.precision(6);
  r << "mfns-calib intrinsics: camera " << o.camera << ", target " << o.target << ", " << width << "x" << height << "\n"
    << "images used " << used.size() << ", skipped " << skipped.size() << ", corners " << z.num_corners << ", RMS "
    << z.rms_px << " px\n";
  const char* names[kNumCameraParams] = {"alpha_x", "alpha_y", "skew", "u0", "v0", "kc1", "kc2", "kc3", "kc4", "kc5"};
  const CameraParamVector v = z.camera.ToVector();
  for (int i = 0; i < kNumCameraParams; ++i)
    r << "  " << names[i] << " = " << v[i] << (z.sigma[i] > 0 ? " +- " + std::to_string(z.sigma[i]) : " (fixed)") << "\n";
  r << "per-view RMS (px):\n";
  for (std::size_t i = 0; i < used.size(); ++i) r << "  " << used[i] << " " << rms[i] << "\n";
  if (!skipped.empty()) r << "skipped:\n";
  for (const SkippedImage& s : skipped) r << "  " << s.image << ": " << s.reason << "\n";
  WriteFileAtomic(std::filesystem::path(o.out_dir) / "report.txt", r.str());
  log << r.str() << "wrote " << yaml.string() << " and report.txt\n";
  return z;
}

}  // namespace mfns::host
