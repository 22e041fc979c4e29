#include "host/calib/app/calibrate.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <mutex>
#include <opencv2/core.hpp>
#include <ostream>
#include <sstream>
#include <thread>

#include "common/rotation/rotation.h"
#include "host/calib/cpc/cpc.h"
#include "host/calib/ml/hand_eye.h"
#include "host/calib/ml/joint.h"
#include "host/calib/ml/orientation.h"
#include "host/core/image.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

std::vector<HandEyeView> TurntableViews(const CalibInput& in, const std::vector<Transform>& T, int only_camera = -1) {
  std::vector<HandEyeView> hv;
  for (std::size_t v = 0; v < in.views.size(); ++v) {
    const ViewObservation& view = in.views[v];
    if (view.kind != ImageKind::kTurntable || (only_camera >= 0 && view.camera != only_camera)) continue;
    hv.push_back({view.camera, view.main_cmd, view.aux_cmd, T[v]});
  }
  return hv;
}

RigCalibration FromHandEye(const CalibInput& in, const IntrinsicsStage& st, const HandEyeResult& he, const char* method) {
  RigCalibration rig;
  rig.method = method;
  rig.C_p_b = in.C_p_b;
  rig.r_p_pb = in.r_p_pb;
  rig.C_w_t = he.C_w_t;
  rig.r_w_wt = he.r_w_wt;
  for (std::size_t k = 0; k < in.cameras.size(); ++k) {
    CameraResult c;
    c.name = in.cameras[k].name;
    c.intrinsics = st.zhang[k].camera;
    c.sigma_intrinsics = st.zhang[k].sigma;
    c.C_k_b = he.C_k_b[k];
    c.r_b_bk = he.r_b_bk[k];
    rig.cameras.push_back(c);
  }
  rig.residuals = RigResiduals(in, rig, st.view_T_w_k);
  SetResidualRms(in, &rig);
  AppendCommandedAngles(in, &rig);
  return rig;
}

// Standard deviation along the minor axis of the target positions of `corners` (all target
// points when null), m: small when the corners lie nearly on a line.
double MinorSpread(const std::vector<Eigen::Vector3d>& target_points, const std::vector<CornerObs>* corners) {
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  Eigen::Matrix2d second = Eigen::Matrix2d::Zero();
  const std::size_t n = corners != nullptr ? corners->size() : target_points.size();
  if (n == 0) return 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d p =
        target_points[corners != nullptr ? static_cast<std::size_t>((*corners)[i].id) : i].head<2>();
    mean += p;
    second += p * p.transpose();
  }
  mean /= static_cast<double>(n);
  const Eigen::Matrix2d cov = second / static_cast<double>(n) - mean * mean.transpose();
  return std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(cov).eigenvalues()[0]));
}

}  // namespace

CalibInput DetectDataset(const CalibDataset& ds, const DetectOptions& detect, int jobs, std::ostream* progress) {
  CalibInput in;
  in.target_points = TargetPoints(ds.target);
  for (const std::string& name : ds.cameras) in.cameras.push_back({name, 0, 0});
  struct Slot {
    bool read_ok = false;
    int width = 0, height = 0;
    DetectResult det;
  };
  std::vector<Slot> slots(ds.images.size());
  std::atomic<std::size_t> next{0};
  std::mutex mu;
  std::size_t done = 0;
  const auto work = [&]() {
    for (std::size_t i = next++; i < ds.images.size(); i = next++) {
      Slot& s = slots[i];
      try {
        const cv::Mat image = ReadPgm(ds.images[i].path.string());
        s.read_ok = true;
        s.width = image.cols;
        s.height = image.rows;
        s.det = DetectTarget(image, ds.target, detect);
      } catch (const PgmError& e) {
        s.det.reason = std::string("unreadable image: ") + e.what();
      }
      std::lock_guard<std::mutex> lock(mu);
      ++done;
      if (progress != nullptr)
        *progress << "detect: " << done << "/" << ds.images.size() << " " << ds.images[i].camera << "/"
                  << ds.images[i].image << (s.det.ok ? " ok, " + std::to_string(s.det.corners.size()) + " corners"
                                                      : " skipped: " + s.det.reason)
                  << "\n";
    }
  };
  std::vector<std::thread> threads;
  for (int t = 1; t < std::max(1, jobs); ++t) threads.emplace_back(work);
  work();
  for (std::thread& t : threads) t.join();
  if (progress != nullptr && detect.corner_refine) {
    CornerRefineStats refine;
    for (const Slot& s : slots) refine.Add(s.det.refine_stats);
    *progress << "corner refinement: " << ToString(refine) << "\n";
  }

  for (std::size_t i = 0; i < ds.images.size(); ++i) {
    const DatasetImage& im = ds.images[i];
    const int k = static_cast<int>(std::find(ds.cameras.begin(), ds.cameras.end(), im.camera) - ds.cameras.begin());
    CameraInfo& cam = in.cameras[static_cast<std::size_t>(k)];
    Slot& s = slots[i];
    if (s.read_ok && cam.width == 0) {
      cam.width = s.width;
      cam.height = s.height;
    }
    if (s.read_ok && (s.width != cam.width || s.height != cam.height)) {
      s.det.ok = false;
      s.det.reason = "image size " + std::to_string(s.width) + "x" + std::to_string(s.height) + " differs from the camera's " +
                     std::to_string(cam.width) + "x" + std::to_string(cam.height);
    }
    if (!s.det.ok) {
      in.skipped.push_back({im.camera, im.image, s.det.reason});
      continue;
    }
    ViewObservation v;
    v.camera = k;
    v.image = im.image;
    v.kind = im.kind;
    v.main_cmd = im.main_cmd;
    v.aux_cmd = im.aux_cmd;
    v.corners = std::move(s.det.corners);
    v.orientation_ambiguous = s.det.orientation_ambiguous;
    in.views.push_back(std::move(v));
  }
  return in;
}

IntrinsicsStage PrepareViews(CalibInput* in, const RigOptions& o) {
  // Views with too few corners, or corners nearly on a line (a partial board's single row),
  // cannot carry a pose: cv::calibrateCamera asserts on them.
  const double full_spread = MinorSpread(in->target_points, nullptr);
  std::vector<ViewObservation> kept;
  for (ViewObservation& v : in->views) {
    const std::string& camera = in->cameras[static_cast<std::size_t>(v.camera)].name;
    if (static_cast<int>(v.corners.size()) < std::max(4, o.min_corners)) {
      in->skipped.push_back({camera, v.image, "only " + std::to_string(v.corners.size()) + " corners"});
      continue;
    }
    if (MinorSpread(in->target_points, &v.corners) < 0.2 * full_spread) {
      in->skipped.push_back({camera, v.image, "corners nearly on a line (" + std::to_string(v.corners.size()) + " corners)"});
      continue;
    }
    kept.push_back(std::move(v));
  }
  in->views = std::move(kept);

  IntrinsicsStage st;
  st.view_T_w_k.resize(in->views.size());
  ZhangOptions zo;
  zo.fix_k3 = o.fix_k3;
  for (std::size_t k = 0; k < in->cameras.size(); ++k) {
    std::vector<std::vector<CornerObs>> views;
    std::vector<std::size_t> index;
    for (std::size_t v = 0; v < in->views.size(); ++v)
      if (in->views[v].camera == static_cast<int>(k)) {
        views.push_back(in->views[v].corners);
        index.push_back(v);
      }
    if (views.size() < 3)
      throw UserError("camera " + in->cameras[k].name + ": " + std::to_string(views.size()) +
                      " usable images, at least 3 needed for its intrinsics");
    ZhangResult z;
    try {
      z = CalibrateZhang(views, in->target_points, in->cameras[k].width, in->cameras[k].height, zo);
    } catch (const cv::Exception& e) {
      throw UserError("camera " + in->cameras[k].name + ": cv::calibrateCamera failed on its " +
                      std::to_string(views.size()) + " images: " + e.err);
    }
    for (std::size_t n = 0; n < index.size(); ++n) st.view_T_w_k[index[n]] = {z.views[n].C_k_w.transpose(), z.views[n].r_w_wk};
    if (o.progress != nullptr)
      *o.progress << "zhang: camera " << in->cameras[k].name << ": " << views.size() << " images, RMS " << z.rms_px
                  << " px, alpha (" << z.camera.alpha_x << ", " << z.camera.alpha_y << ")\n";
    st.zhang.push_back(std::move(z));
  }
  const OrientationReport orient = ResolveOrientation(in, &st.view_T_w_k);
  st.notes = orient.notes;
  if (o.progress != nullptr)
    for (const std::string& n : orient.notes) *o.progress << n << "\n";
  return st;
}

RigCalibration CalibrateRig(CalibInput* in, const RigOptions& o) {
  const IntrinsicsStage st = PrepareViews(in, o);
  return SolveRig(*in, st, o);
}

// A camera whose turntable images were all skipped has no mounting to solve for: the solvers
// would leave C_k_b = I, r_b_bk = 0 with a zero sigma in a rig file that looks calibrated (seen on
// a camera looking along -z_b whose turntable views missed the target). Refused, naming it.
void RequireTurntableViews(const CalibInput& in, const IntrinsicsStage& st, RigMethod method) {
  const std::size_t needed = method == RigMethod::kOpenCvHandEye ? 3 : 1;  // opencv-handeye: per camera
  for (std::size_t k = 0; k < in.cameras.size(); ++k) {
    const std::size_t n = TurntableViews(in, st.view_T_w_k, static_cast<int>(k)).size();
    if (n < needed)
      throw UserError("camera " + in.cameras[k].name + ": " + std::to_string(n) + " usable turntable images (" +
                      std::to_string(needed) + " needed), so its mounting C_k_b, r_b_bk cannot be calibrated: " +
                      "retake them with the target in view, or calibrate its intrinsics alone (mfns-calib intrinsics)");
  }
}

RigCalibration SolveRig(const CalibInput& input, const IntrinsicsStage& st, const RigOptions& o) {
  const CalibInput* in = &input;
  RequireTurntableViews(input, st, o.method);
  RigCalibration rig;
  const std::vector<HandEyeView> hv = TurntableViews(*in, st.view_T_w_k);
  switch (o.method) {
    case RigMethod::kMl: {
      const HandEyeResult he = SolveHandEyeLinear(hv, static_cast<int>(in->cameras.size()), in->C_p_b, in->r_p_pb);
      if (o.progress != nullptr)
        *o.progress << "ml: closed-form start: rotation RMS " << RadToDeg(he.rotation_rms) << " deg, position RMS "
                    << he.position_rms * 1e3 << " mm\n";
      MlStart s;
      for (const ZhangResult& z : st.zhang) {
        s.intrinsics.push_back(z.camera);
        s.sigma_px.push_back(std::max(0.02, z.rms_px / std::sqrt(2.0)));
      }
      s.C_k_b = he.C_k_b;
      s.r_b_bk = he.r_b_bk;
      s.C_w_t = he.C_w_t;
      s.r_w_wt = he.r_w_wt;
      s.view_T_w_k = st.view_T_w_k;
      MlOptions mo;
      mo.fix_k3 = o.fix_k3;
      mo.huber_px = o.huber_px;
      mo.covariance = o.covariance;
      mo.progress = o.progress;
      rig = SolveJointMl(*in, s, mo);
      break;
    }
    case RigMethod::kPaper: {
      // The nominal axis-aligned frames (the paper's after its alignment of A.3) from the closed form.
      const HandEyeResult he = SolveHandEyeLinear(hv, static_cast<int>(in->cameras.size()), in->C_p_b, in->r_p_pb);
      CpcStart s;
      for (const ZhangResult& z : st.zhang) {
        s.intrinsics.push_back(z.camera);
        s.sigma_intrinsics.push_back(z.sigma);
      }
      s.view_T_w_k = st.view_T_w_k;
      s.C0_w_t = NearestAxisAligned(he.C_w_t);
      int ref = 0;
      for (std::size_t k = 0; k < in->cameras.size(); ++k)
        if (in->cameras[k].name == o.reference_camera) ref = static_cast<int>(k);
      s.B0_b_ref = NearestAxisAligned(he.C_k_b[static_cast<std::size_t>(ref)].transpose());
      CpcOptions co;
      co.reference_camera = o.reference_camera;
      co.paper_rows_only = o.paper_rows_only;
      rig = SolveCpc(*in, s, co);
      break;
    }
    case RigMethod::kOpenCvHandEye: {
      // One cv::calibrateRobotWorldHandEye per camera; C_w_t, r_w_wt from the camera with most images.
      HandEyeResult all;
      all.C_k_b.assign(in->cameras.size(), Eigen::Matrix3d::Identity());
      all.r_b_bk.assign(in->cameras.size(), Eigen::Vector3d::Zero());
      std::size_t most = 0;
      for (std::size_t k = 0; k < in->cameras.size(); ++k) {
        const std::vector<HandEyeView> one = TurntableViews(*in, st.view_T_w_k, static_cast<int>(k));  // >= 3
        const HandEyeResult he = SolveHandEyeOpenCv(one, static_cast<int>(in->cameras.size()), in->C_p_b, in->r_p_pb);
        all.C_k_b[k] = he.C_k_b[k];
        all.r_b_bk[k] = he.r_b_bk[k];
        if (one.size() > most) {
          most = one.size();
          all.C_w_t = he.C_w_t;
          all.r_w_wt = he.r_w_wt;
        }
      }
      rig = FromHandEye(*in, st, all, "opencv-handeye");
      rig.notes.push_back("opencv-handeye: cv::calibrateRobotWorldHandEye (Shah) per camera on Zhang's extrinsics; "
                          "no sigma");
      break;
    }
  }
  rig.notes.insert(rig.notes.begin(), st.notes.begin(), st.notes.end());
  return rig;
}

CrossValidation CrossValidateRig(const CalibInput& in, const RigOptions& o) {
  if (o.method != RigMethod::kMl || !o.covariance)
    throw UserError("--cross-validate needs --method ml with its covariance");
  const std::vector<int> halves = CrossValidationHalves(in);
  std::array<RigCalibration, 2> rigs;
  std::array<CalibInput, 2> inputs;
  for (std::size_t h = 0; h < 2; ++h) {
    inputs[h] = HalfInput(in, halves, static_cast<int>(h));
    if (o.progress != nullptr)
      *o.progress << "cross-validation: calibrating half " << h << " (" << inputs[h].views.size() << " images)\n";
    try {
      rigs[h] = CalibrateRig(&inputs[h], o);
    } catch (const UserError& e) {
      throw UserError("--cross-validate: half " + std::to_string(h) + ": " + e.what());
    }
  }
  CrossValidation cv = CompareHalves(rigs[0], rigs[1]);
  for (std::size_t h = 0; h < 2; ++h) {
    cv.views[h] = static_cast<int>(inputs[h].views.size());
    for (const ViewObservation& v : inputs[h].views) ++cv.cameras[static_cast<std::size_t>(v.camera)].images[h];
  }
  return cv;
}

}  // namespace mfns::host
