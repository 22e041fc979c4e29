#include "host/calib/ml/joint.h"

#include <ceres/ceres.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <ostream>
#include <sstream>

#include "common/rotation/rotation.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

using Quat = std::array<double, 4>;  // Eigen order x, y, z, w
using Vec3 = std::array<double, 3>;

Quat ToQuat(const Eigen::Matrix3d& C) {
  const Eigen::Quaterniond q(C);
  return {q.x(), q.y(), q.z(), q.w()};
}
Eigen::Matrix3d ToMatrix(const Quat& q) { return Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized().toRotationMatrix(); }
Vec3 ToArray(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
Eigen::Vector3d ToVector(const Vec3& a) { return {a[0], a[1], a[2]}; }

// The camera model of common/camera/camera.h, templated for automatic differentiation.
template <typename T>
void ProjectT(const T* in, const Eigen::Matrix<T, 3, 1>& p, T* uv) {
  const T x = p(0) / p(2), y = p(1) / p(2);
  const T r2 = x * x + y * y;
  const T radial = T(1) + r2 * (in[kKc1] + r2 * (in[kKc2] + r2 * in[kKc5]));
  const T xd = x * radial + T(2) * in[kKc3] * x * y + in[kKc4] * (r2 + T(2) * x * x);
  const T yd = y * radial + in[kKc3] * (r2 + T(2) * y * y) + T(2) * in[kKc4] * x * y;
  uv[0] = in[kAlphaX] * xd + in[kSkew] * yd + in[kU0];
  uv[1] = in[kAlphaY] * yd + in[kV0];
}

// C_t_p = Rx(aux) Rz(main), active rotations.
template <typename T>
Eigen::Matrix<T, 3, 3> PlatformT(const T& main, const T& aux) {
  using std::cos;
  using std::sin;
  const T cm = cos(main), sm = sin(main), ca = cos(aux), sa = sin(aux);
  Eigen::Matrix<T, 3, 3> Rz, Rx;
  Rz << cm, -sm, T(0), sm, cm, T(0), T(0), T(0), T(1);
  Rx << T(1), T(0), T(0), T(0), ca, -sa, T(0), sa, ca;
  return Rx * Rz;
}

struct TurntableCorner {
  Eigen::Vector3d P_w;
  Eigen::Vector2d uv;
  double inv_sigma;
  Eigen::Matrix3d C_p_b;
  Eigen::Vector3d r_p_pb;

  template <typename T>
  bool operator()(const T* intr, const T* q_b_k, const T* r_b_bk, const T* q_w_t, const T* r_w_wt, const T* ang,
                  T* res) const {
    using V3 = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Eigen::Quaternion<T>> Q_w_t(q_w_t), Q_b_k(q_b_k);
    const V3 p_t = Q_w_t.conjugate() * (P_w.cast<T>() - V3(r_w_wt[0], r_w_wt[1], r_w_wt[2]));
    const V3 p_p = PlatformT(ang[0], ang[1]).transpose() * p_t;
    const V3 p_b = C_p_b.transpose().cast<T>() * (p_p - r_p_pb.cast<T>());
    const V3 p_k = Q_b_k.conjugate() * (p_b - V3(r_b_bk[0], r_b_bk[1], r_b_bk[2]));
    if (!(p_k(2) > T(1e-6))) return false;
    T pred[2];
    ProjectT(intr, p_k, pred);
    res[0] = (pred[0] - T(uv.x())) * T(inv_sigma);
    res[1] = (pred[1] - T(uv.y())) * T(inv_sigma);
    return true;
  }
};

struct FreeCorner {
  Eigen::Vector3d P_w;
  Eigen::Vector2d uv;
  double inv_sigma;

  template <typename T>
  bool operator()(const T* intr, const T* q_w_k, const T* r_w_wk, T* res) const {
    using V3 = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Eigen::Quaternion<T>> Q_w_k(q_w_k);
    const V3 p_k = Q_w_k.conjugate() * (P_w.cast<T>() - V3(r_w_wk[0], r_w_wk[1], r_w_wk[2]));
    if (!(p_k(2) > T(1e-6))) return false;
    T pred[2];
    ProjectT(intr, p_k, pred);
    res[0] = (pred[0] - T(uv.x())) * T(inv_sigma);
    res[1] = (pred[1] - T(uv.y())) * T(inv_sigma);
    return true;
  }
};

struct AnglePrior {
  double main_cmd, aux_cmd, inv_sigma;
  template <typename T>
  bool operator()(const T* ang, T* res) const {
    res[0] = (ang[0] - T(main_cmd)) * T(inv_sigma);
    res[1] = (ang[1] - T(aux_cmd)) * T(inv_sigma);
    return true;
  }
};

struct Params {
  std::vector<std::array<double, kNumCameraParams>> intr;
  std::vector<Quat> q_b_k;
  std::vector<Vec3> r_b_bk;
  Quat q_w_t{};
  Vec3 r_w_wt{};
  std::vector<std::array<double, 2>> ang;  // per view
  std::vector<Quat> q_w_k;                 // per view
  std::vector<Vec3> r_w_wk;
};

class ProgressCallback final : public ceres::IterationCallback {
 public:
  ProgressCallback(std::ostream* out, int pass) : out_(out), pass_(pass) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    if (out_ != nullptr) {
      std::ostringstream line;
      line.precision(6);
      line << "ml: pass " << pass_ << " iteration " << s.iteration << " cost " << s.cost << " |step| " << s.step_norm << "\n";
      *out_ << line.str() << std::flush;
    }
    return ceres::SOLVER_CONTINUE;
  }

 private:
  std::ostream* out_;
  int pass_;
};

struct Layout {
  std::vector<bool> has_turntable;  // per camera
  bool any_turntable = false;
};

Layout MakeLayout(const CalibInput& in) {
  Layout l;
  l.has_turntable.assign(in.cameras.size(), false);
  for (const ViewObservation& v : in.views)
    if (v.kind == ImageKind::kTurntable) l.has_turntable[static_cast<std::size_t>(v.camera)] = true;
  for (bool b : l.has_turntable) l.any_turntable = l.any_turntable || b;
  return l;
}

std::vector<int> FixedIntrinsics(const MlOptions& o) {
  std::vector<int> fixed;
  if (o.fix_skew) fixed.push_back(kSkew);
  if (o.fix_k3) fixed.push_back(kKc5);
  return fixed;
}

void BuildProblem(const CalibInput& in, const Layout& layout, const MlOptions& o, const std::vector<double>& sigma_px,
                  Params* p, ceres::Problem* problem) {
  const std::vector<int> fixed = FixedIntrinsics(o);
  for (std::size_t k = 0; k < in.cameras.size(); ++k) {
    problem->AddParameterBlock(p->intr[k].data(), kNumCameraParams,
                               fixed.empty() ? nullptr : new ceres::SubsetManifold(kNumCameraParams, fixed));
    if (layout.has_turntable[k]) {
      problem->AddParameterBlock(p->q_b_k[k].data(), 4, new ceres::EigenQuaternionManifold);
      problem->AddParameterBlock(p->r_b_bk[k].data(), 3);
    }
  }
  if (layout.any_turntable) {
    problem->AddParameterBlock(p->q_w_t.data(), 4, new ceres::EigenQuaternionManifold);
    problem->AddParameterBlock(p->r_w_wt.data(), 3);
  }
  for (std::size_t v = 0; v < in.views.size(); ++v) {
    const ViewObservation& view = in.views[v];
    const std::size_t k = static_cast<std::size_t>(view.camera);
    const double inv_sigma = 1.0 / sigma_px[k];
    if (view.kind == ImageKind::kTurntable) {
      problem->AddParameterBlock(p->ang[v].data(), 2);
      problem->AddResidualBlock(new ceres::AutoDiffCostFunction<AnglePrior, 2, 2>(
                                    new AnglePrior{view.main_cmd, view.aux_cmd, 1.0 / in.angle_sigma}),
                                nullptr, p->ang[v].data());
    } else {
      problem->AddParameterBlock(p->q_w_k[v].data(), 4, new ceres::EigenQuaternionManifold);
      problem->AddParameterBlock(p->r_w_wk[v].data(), 3);
    }
    for (const CornerObs& c : view.corners) {
      const Eigen::Vector3d& P = in.target_points[static_cast<std::size_t>(c.id)];
      // Whitened residuals: the loss's scale is in sigmas.
      ceres::LossFunction* loss =
          o.huber_px > 0 ? new ceres::HuberLoss(std::min(o.huber_px * inv_sigma, o.robust_sigmas)) : nullptr;
      if (view.kind == ImageKind::kTurntable) {
        problem->AddResidualBlock(new ceres::AutoDiffCostFunction<TurntableCorner, 2, kNumCameraParams, 4, 3, 4, 3, 2>(
                                      new TurntableCorner{P, c.uv, inv_sigma, in.C_p_b, in.r_p_pb}),
                                  loss, p->intr[k].data(), p->q_b_k[k].data(), p->r_b_bk[k].data(), p->q_w_t.data(),
                                  p->r_w_wt.data(), p->ang[v].data());
      } else {
        problem->AddResidualBlock(new ceres::AutoDiffCostFunction<FreeCorner, 2, kNumCameraParams, 4, 3>(
                                      new FreeCorner{P, c.uv, inv_sigma}),
                                  loss, p->intr[k].data(), p->q_w_k[v].data(), p->r_w_wk[v].data());
      }
    }
  }
}

// Unweighted residuals (px) of every view at the current parameters.
std::vector<ViewResidual> Residuals(const CalibInput& in, const Params& p) {
  std::vector<ViewResidual> out;
  for (std::size_t v = 0; v < in.views.size(); ++v) {
    const ViewObservation& view = in.views[v];
    const std::size_t k = static_cast<std::size_t>(view.camera);
    ViewResidual r;
    r.view = static_cast<int>(v);
    double sum2 = 0;
    for (const CornerObs& c : view.corners) {
      const Eigen::Vector3d& P = in.target_points[static_cast<std::size_t>(c.id)];
      double res[2] = {std::nan(""), std::nan("")};
      if (view.kind == ImageKind::kTurntable) {
        TurntableCorner{P, c.uv, 1.0, in.C_p_b, in.r_p_pb}(p.intr[k].data(), p.q_b_k[k].data(), p.r_b_bk[k].data(),
                                                            p.q_w_t.data(), p.r_w_wt.data(), p.ang[v].data(), res);
      } else {
        FreeCorner{P, c.uv, 1.0}(p.intr[k].data(), p.q_w_k[v].data(), p.r_w_wk[v].data(), res);
      }
      r.ids.push_back(c.id);
      r.uv.push_back(c.uv);
      r.residual.emplace_back(res[0], res[1]);
      sum2 += res[0] * res[0] + res[1] * res[1];
    }
    r.rms_px = std::sqrt(sum2 / static_cast<double>(std::max<std::size_t>(1, view.corners.size())));
    out.push_back(std::move(r));
  }
  return out;
}

// Per-axis pixel sigma per camera from the residuals: sqrt(sum r^2 / (2 N - p)), with p the
// camera's own parameters (intrinsics, rig, free poses) and its share of the turntable's.
// Residuals beyond outlier_sigmas (outliers the Huber loss already discounts) are left out.
// *dof (optional): the degrees of freedom per camera.
std::vector<double> EstimateSigma(const CalibInput& in, const Layout& layout, const MlOptions& o,
                                  const std::vector<ViewResidual>& res, const std::vector<double>& previous,
                                  std::vector<double>* dof_out = nullptr) {
  const std::size_t K = in.cameras.size();
  std::vector<double> sum2(K, 0.0), dof(K, 0.0);
  int cams_tt = 0;
  for (bool b : layout.has_turntable) cams_tt += b ? 1 : 0;
  for (std::size_t k = 0; k < K; ++k) {
    dof[k] = -static_cast<double>(kNumCameraParams - FixedIntrinsics(o).size());
    if (layout.has_turntable[k]) dof[k] -= 6.0 + 6.0 / cams_tt;
  }
  for (const ViewResidual& r : res) {
    const ViewObservation& view = in.views[static_cast<std::size_t>(r.view)];
    const std::size_t k = static_cast<std::size_t>(view.camera);
    if (view.kind == ImageKind::kFree) dof[k] -= 6.0;
    for (const Eigen::Vector2d& e : r.residual) {
      if (!e.allFinite() || e.norm() > o.outlier_sigmas * previous[k]) continue;
      sum2[k] += e.squaredNorm();
      dof[k] += 2.0;
    }
  }
  std::vector<double> sigma(K);
  for (std::size_t k = 0; k < K; ++k) sigma[k] = dof[k] > 0 ? std::max(1e-4, std::sqrt(sum2[k] / dof[k])) : previous[k];
  if (dof_out != nullptr) *dof_out = dof;
  return sigma;
}

// The corners beyond outlier_sigmas x their camera's sigma, largest first; counted per camera.
std::vector<OutlierCorner> FindOutliers(const CalibInput& in, const MlOptions& o, const std::vector<ViewResidual>& res,
                                        const std::vector<double>& sigma, RigCalibration* rig) {
  std::vector<OutlierCorner> out;
  for (const ViewResidual& r : res) {
    const std::size_t k = static_cast<std::size_t>(in.views[static_cast<std::size_t>(r.view)].camera);
    for (std::size_t i = 0; i < r.residual.size(); ++i) {
      const double z = r.residual[i].norm() / sigma[k];
      if (!(z > o.outlier_sigmas)) continue;  // NaN (behind the camera) is not counted here
      out.push_back({r.view, r.ids[i], r.residual[i], z});
      ++rig->cameras[k].outliers;
    }
  }
  std::sort(out.begin(), out.end(), [](const OutlierCorner& a, const OutlierCorner& b) { return a.sigmas > b.sigmas; });
  return out;
}

// Camera k's joint covariance (CameraResult::covariance) from the tangent-space covariance of
// its intrinsics, q_b_k and r_b_bk blocks: the intrinsics' tangent is their free entries, and
// EigenQuaternionManifold's tangent delta rotates by 2 delta.
CameraStateCovariance CameraCovariance(const ceres::Covariance& cov, const Params& p, std::size_t k,
                                       const std::vector<int>& fixed) {
  std::vector<int> state;  // tangent index -> state index
  for (int i = 0; i < kNumCameraParams; ++i)
    if (std::find(fixed.begin(), fixed.end(), i) == fixed.end()) state.push_back(i);
  for (int i = 0; i < 6; ++i) state.push_back(kStateRotation + i);
  const int n = static_cast<int>(state.size());
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> t(n, n);
  cov.GetCovarianceMatrixInTangentSpace({p.intr[k].data(), p.q_b_k[k].data(), p.r_b_bk[k].data()}, t.data());
  Eigen::VectorXd scale = Eigen::VectorXd::Ones(n);
  scale.segment<3>(n - 6).setConstant(2.0);
  t = scale.asDiagonal() * t * scale.asDiagonal();
  CameraStateCovariance out = CameraStateCovariance::Zero();
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) out(state[static_cast<std::size_t>(a)], state[static_cast<std::size_t>(b)]) = t(a, b);
  return out;
}

}  // namespace

Eigen::Vector3d EulerSigma(const Eigen::Matrix3d& C_k_b, const Eigen::Matrix3d& cov_phi_b) {
  // C_k_b(phi) = (Exp(phi) C_b_k)^T = C_k_b Exp(-phi).
  const double h = 1e-7;
  const EulerAngles e0 = MatrixToEuler(C_k_b);
  Eigen::Matrix3d J;
  for (int i = 0; i < 3; ++i) {
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    d[i] = h;
    const EulerAngles ep = MatrixToEuler(C_k_b * ExpSO3(-d));
    const EulerAngles em = MatrixToEuler(C_k_b * ExpSO3(d));
    J(0, i) = WrapPi(ep.phi - em.phi) / (2 * h);
    J(1, i) = WrapPi(ep.theta - em.theta) / (2 * h);
    J(2, i) = WrapPi(ep.psi - em.psi) / (2 * h);
    (void)e0;
  }
  const Eigen::Matrix3d cov = J * cov_phi_b * J.transpose();
  return cov.diagonal().cwiseMax(0.0).cwiseSqrt();
}

void SetResidualRms(const CalibInput& in, RigCalibration* rig) {
  const std::size_t K = in.cameras.size();
  std::vector<double> sum2(K, 0.0), n(K, 0.0);
  for (const ViewResidual& r : rig->residuals) {
    const auto k = static_cast<std::size_t>(in.views[static_cast<std::size_t>(r.view)].camera);
    for (const Eigen::Vector2d& e : r.residual) {
      if (!e.allFinite()) continue;
      sum2[k] += e.squaredNorm();
      n[k] += 1;
    }
  }
  double all2 = 0, alln = 0;
  for (std::size_t k = 0; k < K; ++k) {
    rig->cameras[k].rms_px = n[k] > 0 ? std::sqrt(sum2[k] / n[k]) : 0.0;
    all2 += sum2[k];
    alln += n[k];
  }
  rig->rms_px = alln > 0 ? std::sqrt(all2 / alln) : 0.0;
}

void AppendCommandedAngles(const CalibInput& in, RigCalibration* rig) {
  for (std::size_t v = 0; v < in.views.size(); ++v) {
    if (in.views[v].kind != ImageKind::kTurntable) continue;
    AngleResult a;
    a.view = static_cast<int>(v);
    a.main_cmd = a.main_est = in.views[v].main_cmd;
    a.aux_cmd = a.aux_est = in.views[v].aux_cmd;
    rig->angles.push_back(a);
  }
}

std::vector<ViewResidual> RigResiduals(const CalibInput& in, const RigCalibration& rig,
                                       const std::vector<Transform>& view_T_w_k) {
  std::vector<ViewResidual> out;
  TurntableMount m;
  m.C_w_t = rig.C_w_t;
  m.r_w_wt = rig.r_w_wt;
  m.C_p_b = rig.C_p_b;
  m.r_p_pb = rig.r_p_pb;
  for (std::size_t v = 0; v < in.views.size(); ++v) {
    const ViewObservation& view = in.views[v];
    const CameraResult& cam = rig.cameras[static_cast<std::size_t>(view.camera)];
    const Transform T_w_k = view.kind == ImageKind::kTurntable
                                ? CameraInWorld(BodyInWorld(m, view.main_cmd, view.aux_cmd), cam.C_k_b, cam.r_b_bk)
                                : view_T_w_k[v];
    ViewResidual r;
    r.view = static_cast<int>(v);
    double sum2 = 0;
    for (const CornerObs& c : view.corners) {
      const Eigen::Vector3d p_k = T_w_k.C.transpose() * (in.target_points[static_cast<std::size_t>(c.id)] - T_w_k.r);
      Eigen::Vector2d uv = Eigen::Vector2d::Constant(std::nan(""));
      if (Project(cam.intrinsics, p_k, &uv) != ProjectStatus::kOk) uv = Eigen::Vector2d::Constant(std::nan(""));
      r.ids.push_back(c.id);
      r.uv.push_back(c.uv);
      r.residual.push_back(uv - c.uv);
      if (r.residual.back().allFinite()) sum2 += r.residual.back().squaredNorm();
    }
    r.rms_px = std::sqrt(sum2 / static_cast<double>(std::max<std::size_t>(1, view.corners.size())));
    out.push_back(std::move(r));
  }
  return out;
}

RigCalibration SolveJointMl(const CalibInput& in, const MlStart& start, const MlOptions& o) {
  const std::size_t K = in.cameras.size();
  const Layout layout = MakeLayout(in);
  Params p;
  for (std::size_t k = 0; k < K; ++k) {
    std::array<double, kNumCameraParams> a{};
    CameraIntrinsics cam = start.intrinsics[k];
    if (o.fix_skew) cam.skew = 0.0;
    if (o.fix_k3) cam.kc[4] = 0.0;
    const CameraParamVector v = cam.ToVector();
    for (int i = 0; i < kNumCameraParams; ++i) a[static_cast<std::size_t>(i)] = v[i];
    p.intr.push_back(a);
    p.q_b_k.push_back(ToQuat(start.C_k_b[k].transpose()));
    p.r_b_bk.push_back(ToArray(start.r_b_bk[k]));
  }
  p.q_w_t = ToQuat(start.C_w_t);
  p.r_w_wt = ToArray(start.r_w_wt);
  for (std::size_t v = 0; v < in.views.size(); ++v) {
    p.ang.push_back({in.views[v].main_cmd, in.views[v].aux_cmd});
    p.q_w_k.push_back(ToQuat(start.view_T_w_k[v].C));
    p.r_w_wk.push_back(ToArray(start.view_T_w_k[v].r));
  }

  std::vector<double> sigma = start.sigma_px, dof(K, 0.0);
  ceres::Solver::Summary summary;
  for (int pass = 1; pass <= std::max(1, o.reweight_passes); ++pass) {
    ceres::Problem problem;
    BuildProblem(in, layout, o, sigma, &p, &problem);
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    so.max_num_iterations = o.max_iterations;
    // Converged long before these bind at the precision that matters (1e-3 sigma).
    so.function_tolerance = 1e-10;
    so.gradient_tolerance = 1e-12;
    so.parameter_tolerance = 1e-10;
    so.num_threads = 1;
    ProgressCallback cb(o.progress, pass);
    so.callbacks.push_back(&cb);
    ceres::Solve(so, &problem, &summary);
    if (summary.termination_type == ceres::FAILURE || !std::isfinite(summary.final_cost))
      throw UserError("ml: Ceres failed: " + summary.message);
    const std::vector<double> next = EstimateSigma(in, layout, o, Residuals(in, p), sigma, &dof);
    double change = 0;
    for (std::size_t k = 0; k < K; ++k) change = std::max(change, std::abs(next[k] / sigma[k] - 1.0));
    if (o.progress != nullptr) {
      *o.progress << "ml: pass " << pass << ": " << summary.iterations.size() << " iterations, cost "
                  << summary.final_cost << ", pixel sigma";
      for (std::size_t k = 0; k < K; ++k) *o.progress << " " << in.cameras[k].name << " " << next[k];
      *o.progress << " px\n";
    }
    sigma = next;
    if (change < 0.05) break;  // a 5% weight error moves the estimate by far less than its sigma
  }

  RigCalibration rig;
  rig.method = "ml";
  rig.C_p_b = in.C_p_b;
  rig.r_p_pb = in.r_p_pb;
  rig.C_w_t = ToMatrix(p.q_w_t);
  rig.r_w_wt = ToVector(p.r_w_wt);
  rig.residuals = Residuals(in, p);
  for (std::size_t k = 0; k < K; ++k) {
    CameraResult c;
    c.name = in.cameras[k].name;
    CameraParamVector v;
    for (int i = 0; i < kNumCameraParams; ++i) v[i] = p.intr[k][static_cast<std::size_t>(i)];
    c.intrinsics.width = in.cameras[k].width;
    c.intrinsics.height = in.cameras[k].height;
    c.intrinsics.SetFromVector(v);
    c.C_k_b = ToMatrix(p.q_b_k[k]).transpose();
    c.r_b_bk = ToVector(p.r_b_bk[k]);
    rig.cameras.push_back(c);
    if (!layout.has_turntable[k])
      rig.notes.push_back("camera " + c.name + ": no turntable image, so C_k_b and r_b_bk are not estimated");
  }
  for (std::size_t v = 0; v < in.views.size(); ++v) {
    if (in.views[v].kind != ImageKind::kTurntable) continue;
    AngleResult a;
    a.view = static_cast<int>(v);
    a.main_cmd = in.views[v].main_cmd;
    a.aux_cmd = in.views[v].aux_cmd;
    a.main_est = p.ang[v][0];
    a.aux_est = p.ang[v][1];
    rig.angles.push_back(a);
  }
  SetResidualRms(in, &rig);
  for (std::size_t k = 0; k < K; ++k) {
    rig.cameras[k].pixel_sigma = sigma[k];
    rig.cameras[k].pixel_sigma_dof = dof[k];
  }
  rig.outliers = FindOutliers(in, o, rig.residuals, sigma, &rig);
  if (o.progress != nullptr)
    for (const CameraResult& c : rig.cameras)
      *o.progress << "ml: camera " << c.name << ": pixel sigma " << c.pixel_sigma << " px from the residuals ("
                  << c.pixel_sigma_dof << " dof), " << c.outliers << " outlier corners beyond " << o.outlier_sigmas
                  << " sigma (down-weighted)\n";
  {
    std::ostringstream note;
    note << "ml: gauge fixed: C_p_b and r_p_pb (the mount); skew " << (o.fix_skew ? "fixed at 0" : "free") << ", kc5 "
         << (o.fix_k3 ? "fixed at 0" : "free") << "; pixel sigma per camera";
    for (std::size_t k = 0; k < K; ++k) note << " " << in.cameras[k].name << "=" << sigma[k];
    note << " px (from the residuals); Huber loss at min(" << o.huber_px << " px, " << o.robust_sigmas
         << " pixel sigma); " << rig.outliers.size() << " outlier corners beyond " << o.outlier_sigmas << " sigma; "
         << summary.BriefReport();
    rig.notes.push_back(note.str());
  }
  if (!o.covariance) return rig;

  // Covariance of the whitened problem at the solution.
  ceres::Problem problem;
  BuildProblem(in, layout, o, sigma, &p, &problem);
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::SPARSE_QR;
  co.num_threads = 1;
  ceres::Covariance cov(co);
  std::vector<std::pair<const double*, const double*>> blocks;
  for (std::size_t k = 0; k < K; ++k) {
    blocks.emplace_back(p.intr[k].data(), p.intr[k].data());
    if (layout.has_turntable[k]) {
      blocks.emplace_back(p.q_b_k[k].data(), p.q_b_k[k].data());
      blocks.emplace_back(p.r_b_bk[k].data(), p.r_b_bk[k].data());
      // The cross terms: the camera's joint covariance (CameraResult::covariance).
      blocks.emplace_back(p.intr[k].data(), p.q_b_k[k].data());
      blocks.emplace_back(p.intr[k].data(), p.r_b_bk[k].data());
      blocks.emplace_back(p.q_b_k[k].data(), p.r_b_bk[k].data());
    }
  }
  if (layout.any_turntable) {
    blocks.emplace_back(p.q_w_t.data(), p.q_w_t.data());
    blocks.emplace_back(p.r_w_wt.data(), p.r_w_wt.data());
  }
  for (std::size_t v = 0; v < in.views.size(); ++v)
    if (in.views[v].kind == ImageKind::kTurntable) blocks.emplace_back(p.ang[v].data(), p.ang[v].data());
  if (!cov.Compute(blocks, &problem)) {
    rig.notes.push_back("ml: covariance not computed (rank-deficient Jacobian): sigma left at 0");
    return rig;
  }
  // EigenQuaternionManifold's tangent delta rotates by 2 |delta| (Exp(2 delta) applied on the left).
  const auto rot_cov = [&](const double* q) {
    Eigen::Matrix3d c;
    cov.GetCovarianceBlockInTangentSpace(q, q, c.data());
    return Eigen::Matrix3d(4.0 * c);
  };
  for (std::size_t k = 0; k < K; ++k) {
    CameraResult& c = rig.cameras[k];
    Eigen::Matrix<double, kNumCameraParams, kNumCameraParams> ci;
    cov.GetCovarianceBlock(p.intr[k].data(), p.intr[k].data(), ci.data());
    c.sigma_intrinsics = ci.diagonal().cwiseMax(0.0).cwiseSqrt();
    c.covariance.topLeftCorner<kNumCameraParams, kNumCameraParams>() = ci;
    if (!layout.has_turntable[k]) continue;
    c.covariance = CameraCovariance(cov, p, k, FixedIntrinsics(o));
    const Eigen::Matrix3d cr = rot_cov(p.q_b_k[k].data());
    c.sigma_rotation = cr.diagonal().cwiseMax(0.0).cwiseSqrt();
    c.sigma_euler = EulerSigma(c.C_k_b, cr);
    Eigen::Matrix3d ct;
    cov.GetCovarianceBlock(p.r_b_bk[k].data(), p.r_b_bk[k].data(), ct.data());
    c.sigma_r_b_bk = ct.diagonal().cwiseMax(0.0).cwiseSqrt();
  }
  if (layout.any_turntable) {
    rig.sigma_C_w_t = rot_cov(p.q_w_t.data()).diagonal().cwiseMax(0.0).cwiseSqrt();
    Eigen::Matrix3d ct;
    cov.GetCovarianceBlock(p.r_w_wt.data(), p.r_w_wt.data(), ct.data());
    rig.sigma_r_w_wt = ct.diagonal().cwiseMax(0.0).cwiseSqrt();
  }
  for (AngleResult& a : rig.angles) {
    Eigen::Matrix2d ca;
    cov.GetCovarianceBlock(p.ang[static_cast<std::size_t>(a.view)].data(), p.ang[static_cast<std::size_t>(a.view)].data(),
                           ca.data());
    a.main_sigma = std::sqrt(std::max(0.0, ca(0, 0)));
    a.aux_sigma = std::sqrt(std::max(0.0, ca(1, 1)));
  }
  return rig;
}

}  // namespace mfns::host
