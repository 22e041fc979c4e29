#include "host/calib/report/outputs.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <opencv2/core.hpp>
#include <sstream>
#include <utility>
#include <vector>

#include "common/blob/param_blob.h"
#include "common/rotation/rotation.h"
#include "host/calib/report/compare.h"
#include "host/calib/report/svg.h"
#include "host/calib/uncertainty/projection_uncertainty.h"
#include "host/core/svg_writer.h"
#include "host/rigio/rig_yaml.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

double Finite(double v) { return std::isfinite(v) ? v : 0.0; }

Eigen::Matrix4d TCamBody(const CameraResult& c) {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = c.C_k_b;
  T.topRightCorner<3, 1>() = -c.C_k_b * c.r_b_bk;
  return T;
}

void YamlMatrix4(std::ostringstream& o, const char* key, const Eigen::Matrix4d& T) {
  o << "  " << key << ":\n";
  for (int r = 0; r < 4; ++r) {
    o << "  - [";
    for (int c = 0; c < 4; ++c) o << (c ? ", " : "") << General(T(r, c), 15);
    o << "]\n";
  }
}

const char* kParamNames[kNumCameraParams] = {"alpha_x (px)", "alpha_y (px)", "skew (px)", "u0 (px)", "v0 (px)",
                                             "kc1",          "kc2",          "kc3",       "kc4",     "kc5"};

std::string PlusMinus(double v, double s, int prec = 6) {
  return General(v, prec) +
         (s > 0 ? " &plusmn; " + General(s, 3) : std::string(" <span class=\"fixed\">(fixed or no sigma)</span>"));
}

// Grid of the projection-uncertainty maps: cells about 40 px on a 1280-px image.
constexpr int kUncertaintyCols = 32, kUncertaintyRows = 24;

// One heat map of a camera's projection uncertainty with its value at the principal point and
// the worst cell in the title.
std::string ProjectionSigmaSvg(const CameraResult& c, RayFrame frame) {
  const ProjectionSigmaGrid g = ProjectionSigmaMap(c, frame, kUncertaintyCols, kUncertaintyRows);
  const HeatmapGrid grid{g.cols, g.rows, static_cast<double>(c.intrinsics.width),
                         static_cast<double>(c.intrinsics.height), g.sigma_px};
  double worst = 0;
  for (double v : g.sigma_px)
    if (std::isfinite(v)) worst = std::max(worst, v);
  const double centre = ProjectionSigmaPx(c, frame, {c.intrinsics.u0, c.intrinsics.v0});
  return HeatmapSvg(grid,
                    "camera " + c.name + (frame == RayFrame::kBody ? ", body-frame ray" : ", camera-frame ray") +
                        ": centre " + General(centre, 2) + ", worst " + General(worst, 2) + " px",
                    "px");
}

// Per camera with a covariance: the 1-sigma of a reprojected ray over the image
// (uncertainty/projection_uncertainty.h), the ray fixed in the body frame and in the camera frame.
std::string ProjectionUncertaintyHtml(const RigCalibration& rig) {
  std::ostringstream h;
  h << "<h2>Projection uncertainty</h2>\n";
  h << "<p>1-sigma (px, worst direction) of the pixel at which a fixed ray lands, first order: unproject with the "
       "estimate, project with the parameters drawn from their covariance. Body-frame ray: intrinsics and C_k_b "
       "jointly (the rays the flyer navigates with). Camera-frame ray: the intrinsics alone (mrcal's single-camera "
       "map); larger, since the principal point and C_k_b are correlated. Divide by alpha for the ray's angle "
       "(rad).</p>\n<div class=\"charts\">\n";
  bool any = false;
  for (RayFrame frame : {RayFrame::kBody, RayFrame::kCamera})
    for (const CameraResult& c : rig.cameras) {
      if (c.covariance.isZero(0.0)) continue;
      any = true;
      h << ProjectionSigmaSvg(c, frame);
    }
  if (!any) h << "<p>No covariance (method " << XmlEscape(rig.method) << ").</p>";
  h << "</div>\n";
  return h.str();
}

// The outlier corners (ml), largest first, at most 50 rows.
std::string OutliersHtml(const RigCalibration& rig, const CalibInput& in) {
  std::ostringstream h;
  h << "<h3>Outlier corners</h3><p>" << rig.outliers.size()
    << " corners lie beyond 5 sigma of their camera's noise; the Huber loss bounds their pull. Many in one image "
       "mean a bad image or detection.</p>\n<table><tr><th class=\"l\">camera/image</th><th>corner</th>"
       "<th>residual (px)</th><th>sigmas</th></tr>";
  for (std::size_t i = 0; i < rig.outliers.size() && i < 50; ++i) {
    const OutlierCorner& o = rig.outliers[i];
    const ViewObservation& v = in.views[static_cast<std::size_t>(o.view)];
    h << "<tr><td class=\"l\">" << XmlEscape(in.cameras[static_cast<std::size_t>(v.camera)].name + "/" + v.image)
      << "</td><td>" << o.id << "</td><td>(" << Fixed(o.residual.x(), 3) << ", " << Fixed(o.residual.y(), 3)
      << ")</td><td>" << Fixed(o.sigmas, 1) << "</td></tr>";
  }
  h << "</table>\n";
  return h.str();
}

std::string Chi2Cell(const ChiSquareBlock& b) {
  return "<td>" + General(b.chi2, 3) + " / " + std::to_string(b.dof) + "</td>";
}

// The cross-validation (uncertainty/cross_validation.h): one row per camera, the verdict.
std::string CrossValidationHtml(const CrossValidation& cv) {
  std::ostringstream h;
  h << "<h2>Cross-validation</h2>\n<p class=\"" << (cv.pass ? "pass" : "bad") << "\"><b>" << (cv.pass ? "PASS" : "FAIL")
    << "</b>: two halves of " << cv.views[0] << " and " << cv.views[1]
    << " images (each camera's turntable and free images alternating) calibrated apart; each camera's difference "
       "against the sum of the halves' covariances. A camera fails below p = "
    << General(kCrossValidationMinPValue, 2) << "."
    << (cv.pass ? "" : " rig.yaml, calibration.bin and the other outputs were not written.") << "</p>\n";
  h << "<table><tr><th class=\"l\">camera</th><th>images</th><th>C_k_b difference (deg)</th><th>expected (deg)</th>"
       "<th>r_b_bk difference (mm)</th><th>expected (mm)</th><th>chi2 / dof intrinsics</th><th>rotation</th>"
       "<th>position</th><th>chi2 / dof all</th><th>p</th><th class=\"l\">verdict</th></tr>\n";
  for (const CameraCrossValidation& c : cv.cameras)
    h << "<tr><td class=\"l\">" << XmlEscape(c.name) << "</td><td>" << c.images[0] << " + " << c.images[1]
      << "</td><td>" << General(c.rotation_deg, 3) << "</td><td>" << General(c.rotation_sigma_deg, 3) << "</td><td>"
      << General(c.position_mm, 3) << "</td><td>" << General(c.position_sigma_mm, 3) << "</td>"
      << Chi2Cell(c.intrinsics) << Chi2Cell(c.rotation) << Chi2Cell(c.position) << Chi2Cell(c.all) << "<td>"
      << General(c.all.p_value, 3) << "</td><td class=\"l" << (c.pass ? "" : " bad") << "\">"
      << (c.pass ? "pass" : "FAIL") << "</td></tr>\n";
  h << "</table>\n";
  return h.str();
}

}  // namespace

Rig ToRig(const RigCalibration& cal, const std::string& rig_id) {
  Rig rig;
  std::strncpy(rig.rig_id.data(), rig_id.c_str(), rig.rig_id.size() - 1);
  rig.num_cameras = static_cast<int>(cal.cameras.size());
  rig.has_sigma = true;
  for (std::size_t k = 0; k < cal.cameras.size(); ++k) {
    const CameraResult& c = cal.cameras[k];
    RigCamera& rc = rig.cameras[k];
    std::strncpy(rc.name.data(), c.name.c_str(), rc.name.size() - 1);
    rc.intrinsics = c.intrinsics;
    rc.C_k_b = c.C_k_b;
    rc.r_b_bk = c.r_b_bk;
    RigCameraSigma& s = rig.sigma[k];
    for (int i = 0; i < 5; ++i) {
      s.intrinsics[static_cast<std::size_t>(i)] = Finite(c.sigma_intrinsics[i]);
      s.distortion[static_cast<std::size_t>(i)] = Finite(c.sigma_intrinsics[kKc1 + i]);
    }
    s.euler = c.sigma_euler.unaryExpr([](double v) { return Finite(v); });
    s.r_b_bk = c.sigma_r_b_bk.unaryExpr([](double v) { return Finite(v); });
  }
  return rig;
}

std::string FormatCamchainYaml(const RigCalibration& rig) {
  std::ostringstream o;
  o << "# Kalibr-style camera chain written by mfns-calib (" << rig.method << ").\n"
    << "# T_cam_body: body -> camera (Kalibr's T_cam_imu with the MFNS body frame b in the IMU's place), metres.\n"
    << "# T_cn_cnm1: camera n from camera n-1 (the cameras do not overlap: derived through the body).\n";
  for (std::size_t k = 0; k < rig.cameras.size(); ++k) {
    const CameraResult& c = rig.cameras[k];
    const CameraIntrinsics& in = c.intrinsics;
    o << "cam" << k << ":\n";
    o << "  camera_model: pinhole\n";
    o << "  intrinsics: [" << General(in.alpha_x, 15) << ", " << General(in.alpha_y, 15) << ", "
      << General(in.u0, 15) << ", " << General(in.v0, 15) << "]\n";
    o << "  distortion_model: radtan\n";
    o << "  distortion_coeffs: [" << General(in.kc[0], 15) << ", " << General(in.kc[1], 15) << ", "
      << General(in.kc[2], 15) << ", " << General(in.kc[3], 15) << "]\n";
    if (in.kc[4] != 0.0) o << "  # kc5 (k3) = " << General(in.kc[4], 15) << " is not part of Kalibr's radtan model\n";
    if (in.skew != 0.0) o << "  # skew = " << General(in.skew, 15) << " px is not part of Kalibr's pinhole model\n";
    o << "  resolution: [" << in.width << ", " << in.height << "]\n";
    YamlMatrix4(o, "T_cam_body", TCamBody(c));
    if (k > 0) YamlMatrix4(o, "T_cn_cnm1", TCamBody(c) * TCamBody(rig.cameras[k - 1]).inverse());
    o << "  rostopic: /mfns/cam_" << c.name << "/image_raw\n";
    o << "  mfns_camera: " << c.name << "\n";
  }
  return o.str();
}

std::string FormatOpenCvCameraYaml(const CameraResult& c, const std::vector<std::string>& view_names,
                                   const std::vector<double>& view_rms, bool with_extrinsics) {
  cv::FileStorage fs(".yaml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  const CameraIntrinsics& in = c.intrinsics;
  fs << "camera_name" << c.name;
  fs << "image_width" << in.width << "image_height" << in.height;
  const cv::Mat K = (cv::Mat_<double>(3, 3) << in.alpha_x, in.skew, in.u0, 0, in.alpha_y, in.v0, 0, 0, 1);
  const cv::Mat D = (cv::Mat_<double>(1, 5) << in.kc[0], in.kc[1], in.kc[2], in.kc[3], in.kc[4]);
  fs << "camera_matrix" << K;
  fs << "distortion_model" << "plumb_bob";
  fs << "distortion_coefficients" << D;
  const CameraParamVector& s = c.sigma_intrinsics;
  fs << "sigma_alpha_skew_u0_v0" << (cv::Mat_<double>(1, 5) << s[kAlphaX], s[kAlphaY], s[kSkew], s[kU0], s[kV0]);
  fs << "sigma_distortion_coefficients" << (cv::Mat_<double>(1, 5) << s[kKc1], s[kKc2], s[kKc3], s[kKc4], s[kKc5]);
  fs << "rms_px" << c.rms_px;
  if (with_extrinsics) {
    cv::Mat T(4, 4, CV_64F);
    const Eigen::Matrix4d t = TCamBody(c);
    for (int r = 0; r < 4; ++r)
      for (int col = 0; col < 4; ++col) T.at<double>(r, col) = t(r, col);
    fs << "T_cam_body" << T;
    fs << "sigma_rotation_body_axes_deg"
       << (cv::Mat_<double>(1, 3) << RadToDeg(c.sigma_rotation.x()), RadToDeg(c.sigma_rotation.y()),
           RadToDeg(c.sigma_rotation.z()));
    fs << "sigma_r_b_bk_mm"
       << (cv::Mat_<double>(1, 3) << c.sigma_r_b_bk.x() * 1e3, c.sigma_r_b_bk.y() * 1e3, c.sigma_r_b_bk.z() * 1e3);
  }
  if (!view_names.empty()) {
    fs << "views" << "[";
    for (std::size_t i = 0; i < view_names.size() && i < view_rms.size(); ++i)
      fs << "{" << "image" << view_names[i] << "rms_px" << view_rms[i] << "}";
    fs << "]";
  }
  return fs.releaseAndGetString();
}

std::string ReportPageHead(const std::string& title, const std::string& extra_css) {
  return "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>" + XmlEscape(title) +
         "</title>\n<style>body{font-family:sans-serif;margin:24px;max-width:1400px}"
         "table{border-collapse:collapse;margin:8px 0}td,th{border:1px solid #bbb;padding:3px 8px;text-align:right}"
         "th{background:#eee}td.l,th.l{text-align:left}h2{border-bottom:1px solid #ccc}.bad{color:#b00}" +
         extra_css + "</style></head><body>\n";
}

std::string FormatReportHtml(const RigCalibration& rig, const CalibInput& in, const ReportContext& ctx) {
  std::ostringstream h;
  h << ReportPageHead(
      ctx.title, ".fixed{color:#888;font-size:smaller}.charts{display:flex;flex-wrap:wrap;gap:8px}.pass{color:#070}");
  h << "<h1>" << XmlEscape(ctx.title) << "</h1>\n<table>";
  int n_tt = 0, n_free = 0, n_corners = 0;
  for (const ViewObservation& v : in.views) {
    (v.kind == ImageKind::kTurntable ? n_tt : n_free) += 1;
    n_corners += static_cast<int>(v.corners.size());
  }
  const auto row = [&](const std::string& k, const std::string& v) {
    h << "<tr><th class=\"l\">" << XmlEscape(k) << "</th><td class=\"l\">" << v << "</td></tr>";
  };
  row("method", XmlEscape(rig.method));
  if (!ctx.dataset.empty()) row("dataset", XmlEscape(ctx.dataset));
  if (!ctx.command_line.empty()) row("command", "<code>" + XmlEscape(ctx.command_line) + "</code>");
  row("rig id / generation", XmlEscape(ctx.rig_id) + " / " + std::to_string(ctx.generation));
  row("images used", std::to_string(n_tt) + " turntable + " + std::to_string(n_free) + " free, " +
                         std::to_string(n_corners) + " corners");
  row("images skipped", std::to_string(in.skipped.size()));
  row("reprojection RMS", General(rig.rms_px, 4) + " px");
  h << "</table>\n<h2>Notes</h2><ul>";
  for (const std::string& n : rig.notes) h << "<li>" << XmlEscape(n) << "</li>";
  h << "</ul>\n";
  if (ctx.cross_validation != nullptr) h << CrossValidationHtml(*ctx.cross_validation);

  // Parameters.
  h << "<h2>Parameters (1-sigma)</h2>\n<table><tr><th class=\"l\">parameter</th>";
  for (const CameraResult& c : rig.cameras) h << "<th>camera " << XmlEscape(c.name) << "</th>";
  h << "</tr>\n";
  for (int i = 0; i < kNumCameraParams; ++i) {
    h << "<tr><td class=\"l\">" << kParamNames[i] << "</td>";
    for (const CameraResult& c : rig.cameras) h << "<td>" << PlusMinus(c.intrinsics.ToVector()[i], c.sigma_intrinsics[i]) << "</td>";
    h << "</tr>\n";
  }
  const char* euler_names[3] = {"phi (deg) of C_k_b", "theta (deg)", "psi (deg)"};
  for (int a = 0; a < 3; ++a) {
    h << "<tr><td class=\"l\">" << euler_names[a] << "</td>";
    for (const CameraResult& c : rig.cameras) {
      const EulerAngles e = MatrixToEuler(c.C_k_b);
      const double v[3] = {e.phi, e.theta, e.psi};
      h << "<td>" << PlusMinus(RadToDeg(v[a]), RadToDeg(c.sigma_euler[a])) << "</td>";
    }
    h << "</tr>\n";
  }
  const char* axes[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    h << "<tr><td class=\"l\">rotation sigma about body " << axes[a] << " (deg)</td>";
    for (const CameraResult& c : rig.cameras) h << "<td>" << General(RadToDeg(c.sigma_rotation[a]), 3) << "</td>";
    h << "</tr>\n";
  }
  for (int a = 0; a < 3; ++a) {
    h << "<tr><td class=\"l\">r_b_bk." << axes[a] << " (mm)</td>";
    for (const CameraResult& c : rig.cameras) h << "<td>" << PlusMinus(c.r_b_bk[a] * 1e3, c.sigma_r_b_bk[a] * 1e3) << "</td>";
    h << "</tr>\n";
  }
  h << "<tr><td class=\"l\">RMS (px)</td>";
  for (const CameraResult& c : rig.cameras) h << "<td>" << General(c.rms_px, 4) << "</td>";
  h << "</tr>\n";
  if (rig.method == "ml") {
    h << "<tr><td class=\"l\">pixel sigma from the residuals (px, dof)</td>";
    for (const CameraResult& c : rig.cameras)
      h << "<td>" << General(c.pixel_sigma, 4) << " (" << General(c.pixel_sigma_dof, 6) << ")</td>";
    h << "</tr>\n<tr><td class=\"l\">outlier corners (down-weighted)</td>";
    for (const CameraResult& c : rig.cameras)
      h << "<td" << (c.outliers > 0 ? " class=\"bad\"" : "") << ">" << c.outliers << "</td>";
    h << "</tr>\n";
  }
  h << "</table>\n";
  if (!rig.outliers.empty()) h << OutliersHtml(rig, in);

  h << "<h3>Turntable and mount</h3><table><tr><th class=\"l\">parameter</th><th>value</th><th>1-sigma</th></tr>";
  {
    const EulerAngles e = MatrixToEuler(rig.C_w_t);
    const double v[3] = {e.phi, e.theta, e.psi};
    const char* n[3] = {"C_w_t Euler alpha (deg)", "C_w_t Euler beta (deg)", "C_w_t Euler gamma (deg)"};
    for (int a = 0; a < 3; ++a)
      h << "<tr><td class=\"l\">" << n[a] << "</td><td>" << General(RadToDeg(v[a]), 7) << "</td><td>"
        << General(RadToDeg(rig.sigma_C_w_t[a]), 3) << " (about w " << axes[a] << ")</td></tr>";
    for (int a = 0; a < 3; ++a)
      h << "<tr><td class=\"l\">r_w_wt." << axes[a] << " (mm)</td><td>" << General(rig.r_w_wt[a] * 1e3, 8) << "</td><td>"
        << General(rig.sigma_r_w_wt[a] * 1e3, 3) << "</td></tr>";
    for (int a = 0; a < 3; ++a)
      h << "<tr><td class=\"l\">r_p_pb." << axes[a] << " (mm)</td><td>" << General(rig.r_p_pb[a] * 1e3, 8)
        << "</td><td class=\"fixed\">fixed (gauge)</td></tr>";
    h << "<tr><td class=\"l\">C_p_b</td><td class=\"l\">" << (rig.C_p_b.isIdentity(1e-12) ? "identity" : "given")
      << "</td><td class=\"fixed\">fixed (gauge)</td></tr></table>\n";
  }

  // Truth.
  if (ctx.truth_rig != nullptr) {
    const RigErrors e = CompareRig(rig, *ctx.truth_rig, ctx.truth_mount);
    h << "<h2>Against the simulation truth</h2><table><tr><th class=\"l\">camera</th><th>C_k_b error (deg)</th>"
         "<th>r_b_bk error (mm)</th></tr>";
    for (const CameraError& c : e.cameras)
      h << "<tr><td class=\"l\">" << XmlEscape(c.name) << "</td><td>" << General(c.rotation_deg, 4) << "</td><td>"
        << General(c.position_mm, 4) << "</td></tr>";
    if (ctx.truth_mount != nullptr)
      h << "<tr><td class=\"l\">turntable</td><td>" << General(e.C_w_t_deg, 4) << "</td><td>" << General(e.r_w_wt_mm, 4) << "</td></tr>";
    h << "</table><table><tr><th class=\"l\">parameter</th><th>estimate - truth</th><th>1-sigma</th><th>|error| / sigma</th></tr>";
    for (const ParamError& p : e.params) {
      const double z = p.sigma > 0 ? std::abs(p.error) / p.sigma : std::nan("");
      h << "<tr><td class=\"l\">" << XmlEscape(p.name) << " (" << p.unit << ")</td><td>" << General(p.error, 4) << "</td><td>"
        << General(p.sigma, 3) << "</td><td" << (z > 3 ? " class=\"bad\"" : "") << ">" << (std::isfinite(z) ? General(z, 3) : "-")
        << "</td></tr>";
    }
    h << "</table>\n";
  }

  h << ProjectionUncertaintyHtml(rig);

  // Residuals per camera.
  h << "<h2>Residuals per camera</h2>\n";
  for (std::size_t k = 0; k < rig.cameras.size(); ++k) {
    SvgChart scatter;
    scatter.title = "camera " + rig.cameras[k].name + ": residuals (predicted - observed)";
    scatter.x_label = "du (px)";
    scatter.y_label = "dv (px)";
    scatter.equal_axes = true;
    SvgSeries tt{"turntable", "res-turntable", "#1f77b4", {}, {}}, fr{"free", "res-free", "#ff7f0e", {}, {}};
    std::vector<double> comps;
    std::vector<std::string> names;
    std::vector<double> rms;
    for (const ViewResidual& r : rig.residuals) {
      const ViewObservation& v = in.views[static_cast<std::size_t>(r.view)];
      if (v.camera != static_cast<int>(k)) continue;
      SvgSeries& s = v.kind == ImageKind::kTurntable ? tt : fr;
      for (const Eigen::Vector2d& e : r.residual) {
        s.x.push_back(e.x());
        s.y.push_back(e.y());
        comps.push_back(e.x());
        comps.push_back(e.y());
      }
      names.push_back(v.image);
      rms.push_back(r.rms_px);
    }
    scatter.series = {tt, fr};
    h << "<h3>camera " << XmlEscape(rig.cameras[k].name) << " (RMS " << General(rig.cameras[k].rms_px, 4)
      << " px)</h3><div class=\"charts\">\n"
      << ScatterSvg(scatter)
      << HistogramSvg(comps, 30, "camera " + rig.cameras[k].name + ": residual components", "px")
      << BarSvg(names, rms, "camera " + rig.cameras[k].name + ": RMS per image", "RMS (px)") << "</div>\n";
  }

  // Turntable angles.
  h << "<h2>Turntable angles</h2>\n";
  if (rig.angles.empty()) {
    h << "<p>No turntable images.</p>\n";
  } else {
    SvgChart ch;
    ch.title = "estimated - commanded turntable angle";
    ch.x_label = "turntable image";
    ch.y_label = "arcsec";
    SvgSeries m{"main", "angle-main", "#1f77b4", {}, {}}, a{"aux", "angle-aux", "#d62728", {}, {}};
    h << "<div class=\"charts\">";
    std::ostringstream table;
    table << "<table><tr><th class=\"l\">image</th><th>main cmd (deg)</th><th>main est - cmd (arcsec)</th><th>sigma</th>"
             "<th>aux cmd (deg)</th><th>aux est - cmd (arcsec)</th><th>sigma</th></tr>";
    for (std::size_t i = 0; i < rig.angles.size(); ++i) {
      const AngleResult& ar = rig.angles[i];
      const ViewObservation& v = in.views[static_cast<std::size_t>(ar.view)];
      const double dm = RadToDeg(ar.main_est - ar.main_cmd) * 3600, da = RadToDeg(ar.aux_est - ar.aux_cmd) * 3600;
      m.x.push_back(static_cast<double>(i));
      m.y.push_back(dm);
      a.x.push_back(static_cast<double>(i));
      a.y.push_back(da);
      table << "<tr><td class=\"l\">" << XmlEscape(in.cameras[static_cast<std::size_t>(v.camera)].name + "/" + v.image) << "</td><td>"
            << Fixed(RadToDeg(ar.main_cmd), 4) << "</td><td>" << Fixed(dm, 2) << "</td><td>"
            << Fixed(RadToDeg(ar.main_sigma) * 3600, 2) << "</td><td>" << Fixed(RadToDeg(ar.aux_cmd), 4) << "</td><td>"
            << Fixed(da, 2) << "</td><td>" << Fixed(RadToDeg(ar.aux_sigma) * 3600, 2) << "</td></tr>";
    }
    ch.series = {m, a};
    h << ScatterSvg(ch) << "</div>\n" << table.str() << "</table>\n";
    if (rig.method != "ml") h << "<p>This method takes the commanded angles as exact.</p>\n";
  }

  // Skipped.
  h << "<h2>Skipped images</h2>\n";
  if (in.skipped.empty()) {
    h << "<p>None.</p>\n";
  } else {
    h << "<table><tr><th class=\"l\">camera</th><th class=\"l\">image</th><th class=\"l\">reason</th></tr>";
    for (const SkippedImage& s : in.skipped)
      h << "<tr><td class=\"l\">" << XmlEscape(s.camera) << "</td><td class=\"l\">" << XmlEscape(s.image) << "</td><td class=\"l\">"
        << XmlEscape(s.reason) << "</td></tr>";
    h << "</table>\n";
  }
  h << "</body></html>\n";
  return h.str();
}

void WriteRigOutputs(const std::filesystem::path& out_dir, const RigCalibration& rig, const CalibInput& in,
                     const ReportContext& ctx) {
  // Everything is formatted (and the rig validated) before the first byte is written, and
  // rig.yaml, the file people and tools take as "the result", is written last: a run that
  // fails anywhere leaves a previous rig.yaml untouched, and each file is replaced atomically.
  const Rig out = ToRig(rig, ctx.rig_id);
  int bad_camera = -1;
  if (const RigStatus v = ValidateRig(out, &bad_camera); v != RigStatus::kOk)
    throw UserError("the calibrated rig is invalid (" + std::string(ToString(v)) + ", camera index " +
                    std::to_string(bad_camera) + "): nothing written");
  std::vector<std::pair<std::string, std::string>> files;  // name, contents
  std::vector<std::uint8_t> bytes(limits::kMaxBlobBytes);
  std::size_t written = 0;
  const BlobStatus s = EncodeParamBlob(out, ctx.generation, bytes, &written);
  if (s != BlobStatus::kOk) throw UserError("cannot encode the parameter blob: " + std::string(ToString(s)));
  files.emplace_back("calibration.bin", std::string(reinterpret_cast<const char*>(bytes.data()), written));
  files.emplace_back("camchain.yaml", FormatCamchainYaml(rig));
  for (std::size_t k = 0; k < rig.cameras.size(); ++k) {
    std::vector<std::string> names;
    std::vector<double> rms;
    for (const ViewResidual& r : rig.residuals) {
      const ViewObservation& v = in.views[static_cast<std::size_t>(r.view)];
      if (v.camera != static_cast<int>(k)) continue;
      names.push_back(v.image + " (" + ToString(v.kind) + ")");
      rms.push_back(r.rms_px);
    }
    files.emplace_back("camera-" + rig.cameras[k].name + ".yaml", FormatOpenCvCameraYaml(rig.cameras[k], names, rms, true));
  }
  files.emplace_back("report.html", FormatReportHtml(rig, in, ctx));
  files.emplace_back("rig.yaml", FormatRigYaml(out));  // last
  const CrossValidation* cv = ctx.cross_validation;
  if (cv != nullptr) {
    files.insert(files.end() - 1, {"crossval.csv", FormatCrossValidationCsv(*cv)});
    if (!cv->pass)  // the diagnosis only: a rig whose halves disagree replaces nothing
      std::erase_if(files, [](const auto& f) { return f.first != "report.html" && f.first != "crossval.csv"; });
  }

  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (!std::filesystem::is_directory(out_dir)) throw UserError(out_dir.string() + ": cannot create the output directory");
  for (const auto& [name, contents] : files) WriteFileAtomic(out_dir / name, contents);
  if (cv != nullptr && !cv->pass)
    throw UserError("cross-validation failed (" + FailedCameras(*cv) +
                    "): rig.yaml and calibration.bin not written; see " + (out_dir / "report.html").string());
}

}  // namespace mfns::host
