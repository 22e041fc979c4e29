#include "host/calib/survey/survey.h"

#include <ceres/ceres.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <memory>
#include <ostream>
#include <string>

#include "common/camera/camera.h"
#include "common/rotation/rotation.h"
#include "host/util/user_error.h"

namespace mfns::host {

bool SurveyOptions::IsValid(const char** why) const {
  const char* bad = nullptr;
  if (!(start_sigma_px > 0.0) || !std::isfinite(start_sigma_px)) bad = "start_sigma_px";
  else if (reweight_passes < 1 || reweight_passes > 10) bad = "reweight_passes";
  else if (relinearise_passes < 1 || relinearise_passes > 20) bad = "relinearise_passes";
  else if (!(huber_sigmas > 0.0) || !std::isfinite(huber_sigmas)) bad = "huber_sigmas";
  else if (max_iterations < 1) bad = "max_iterations";
  else if (!(moved_sigmas > 0.0) || !std::isfinite(moved_sigmas)) bad = "moved_sigmas";
  else if (threads < 1) bad = "threads";
  else if (!(turntable_wobble_rad > 0.0) || !std::isfinite(turntable_wobble_rad)) bad = "turntable_wobble_rad";
  for (const TurntablePlacement& t : turntables)
    if (bad == nullptr && !t.IsValid(&bad)) break;
  if (why != nullptr) *why = bad;
  return bad == nullptr;
}

namespace {

// The image of a beacon through the navigation model (common/rig ProjectBeacon, eq. 2) at the
// pose Retract(ref, delta), and (with a camera block) the camera's mounting perturbed as
// SurveyCamera says. Parameters are perturbations from references held outside Ceres (their
// Jacobians exact at every value, through SO(3)'s right Jacobian); the solve is repeated with
// each perturbation folded into its reference until they vanish, so the covariance is taken
// about the optimum itself.
// Blocks: pose delta (6), beacon (3), [pivot (6): p_b, p_w; the pose's position is then
// p_w - C_w_b p_b and its delta's translation is held], [camera delta (6): dtheta_k, dr_b].
class BeaconImageCost final : public ceres::CostFunction {
 public:
  BeaconImageCost(const RigCamera& cam, const BodyPose& ref, const Eigen::Vector2d& uv, double inv_sigma,
                  bool pivot_block, bool camera_block)
      : cam_(cam), ref_(ref), uv_(uv), inv_sigma_(inv_sigma), pivot_(pivot_block), camera_block_(camera_block) {
    set_num_residuals(2);
    mutable_parameter_block_sizes()->push_back(6);
    mutable_parameter_block_sizes()->push_back(3);
    if (pivot_block) mutable_parameter_block_sizes()->push_back(6);
    if (camera_block) mutable_parameter_block_sizes()->push_back(6);
  }

  bool Evaluate(double const* const* params, double* residuals, double** jacobians) const override {
    BodyPose pose = Retract(ref_, Eigen::Map<const PoseDelta>(params[0]));
    const Eigen::Vector3d P_w = Eigen::Map<const Eigen::Vector3d>(params[1]);
    const int cam_at = pivot_ ? 3 : 2;
    Eigen::Vector3d p_b_pivot = Eigen::Vector3d::Zero();
    if (pivot_) {  // r_w_wb = p_w - C_w_b p_b (the delta's translation is held at zero)
      p_b_pivot = Eigen::Map<const Eigen::Vector3d>(params[2]);
      pose.r_w_wb = Eigen::Map<const Eigen::Vector3d>(params[2] + 3) - pose.C_w_b * p_b_pivot;
    }
    RigCamera cam = cam_;
    if (camera_block_) {
      cam.C_k_b = ExpSO3(Eigen::Map<const Eigen::Vector3d>(params[cam_at])) * cam_.C_k_b;
      cam.r_b_bk = cam_.r_b_bk + Eigen::Map<const Eigen::Vector3d>(params[cam_at] + 3);
    }
    const Eigen::Matrix3d C_b_w = pose.C_w_b.transpose();
    const Eigen::Vector3d p_b = C_b_w * (P_w - pose.r_w_wb);
    const Eigen::Vector3d p_k = cam.C_k_b * (p_b - cam.r_b_bk);
    Eigen::Vector2d uv;
    Eigen::Matrix<double, 2, 3> J_uv_pk;
    if (Project(cam.intrinsics, p_k, &uv, &J_uv_pk) != ProjectStatus::kOk) return false;
    Eigen::Map<Eigen::Vector2d> res(residuals);
    res = (uv - uv_) * inv_sigma_;
    if (jacobians == nullptr) return true;
    const Eigen::Matrix<double, 2, 3> J_uv_pb = J_uv_pk * cam.C_k_b * inv_sigma_;
    const Eigen::Matrix<double, 2, 3> J_r = -J_uv_pb * C_b_w;  // d uv / d r_w_wb
    if (jacobians[0] != nullptr) {  // as ProjectBeacon: dp_b = -C_b_w dr_w + [p_b]x dtheta_b
      Eigen::Map<Eigen::Matrix<double, 2, 6, Eigen::RowMajor>> j(jacobians[0]);
      j.leftCols<3>() = J_r;
      j.rightCols<3>() = J_uv_pb * Skew(p_b);
      // With a pivot the delta's translation changes nothing, and dtheta_b also moves
      // r_w_wb = p_w - C_w_b p_b by C_w_b [p_b]x dtheta_b.
      if (pivot_) {
        j.leftCols<3>().setZero();
        j.rightCols<3>() += J_r * pose.C_w_b * Skew(p_b_pivot);
      }
      // C_w_b = C_ref Exp(dtheta): a perturbation at the current attitude is J_r(dtheta) ddtheta.
      j.rightCols<3>() = (j.rightCols<3>() * RightJacobianSO3(Eigen::Map<const Eigen::Vector3d>(params[0] + 3))).eval();
    }
    if (pivot_ && jacobians[2] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 2, 6, Eigen::RowMajor>> j(jacobians[2]);
      j.leftCols<3>() = -J_r * pose.C_w_b;
      j.rightCols<3>() = J_r;
    }
    if (jacobians[1] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> j(jacobians[1]);
      j = J_uv_pb * C_b_w;
    }
    if (camera_block_ && jacobians[cam_at] != nullptr) {  // dp_k = -[p_k]x dtheta_k - C_k_b dr_b
      Eigen::Map<Eigen::Matrix<double, 2, 6, Eigen::RowMajor>> j(jacobians[cam_at]);
      // C_k_b = Exp(dtheta_k) C_ref: a perturbation on the left is J_r(-dtheta_k) ddtheta_k.
      j.leftCols<3>() = -J_uv_pk * Skew(p_k) * inv_sigma_ *
                        RightJacobianSO3(-Eigen::Map<const Eigen::Vector3d>(params[cam_at]));
      j.rightCols<3>() = -J_uv_pb;
    }
    return true;
  }

 private:
  const RigCamera cam_;
  const BodyPose ref_;
  const Eigen::Vector2d uv_;
  const double inv_sigma_;
  const bool pivot_;
  const bool camera_block_;
};

// The body's position on a pivot pv = (p_b, p_w) at attitude C_w_b: r_w_wb = p_w - C_w_b p_b.
Eigen::Vector3d PivotPosition(const std::array<double, 6>& pv, const Eigen::Matrix3d& C_w_b) {
  return Eigen::Vector3d(pv[3], pv[4], pv[5]) - C_w_b * Eigen::Vector3d(pv[0], pv[1], pv[2]);
}

// A point known to 1-sigma sigma per coordinate as a Gaussian prior on the 3 parameters at
// `offset` of its block: a surveyed beacon, a turntable's surveyed centre (p_w) or its centre in
// the body (p_b; without the mount, its start by 1 m: a run about one axis leaves it free along
// the axis, where it changes no pose), a turntable's surveyed axis.
struct PointPrior {
  Eigen::Vector3d P0;
  double inv_sigma;
  int offset = 0;
  template <typename T>
  bool operator()(const T* P, T* res) const {
    for (int i = 0; i < 3; ++i) res[i] = (P[offset + i] - T(P0(i))) * T(inv_sigma);
    return true;
  }
};

// A turntable run about one axis: the pose's attitude C_w_b = C_ref Exp(dtheta) maps the body
// axis a_b to the world axis a_w, r = (C_w_b a_b - a_w) / wobble. Blocks: pose delta (6;
// its translation unused), a_b (3), a_w (3), both unit (SphereManifold).
class TurntableAxisCost final : public ceres::SizedCostFunction<3, 6, 3, 3> {
 public:
  TurntableAxisCost(const Eigen::Matrix3d& C_ref, double inv_wobble) : C_ref_(C_ref), inv_(inv_wobble) {}

  bool Evaluate(double const* const* params, double* residuals, double** jacobians) const override {
    const Eigen::Vector3d dtheta = Eigen::Map<const Eigen::Vector3d>(params[0] + 3);
    const Eigen::Matrix3d C = C_ref_ * ExpSO3(dtheta);
    const Eigen::Vector3d a_b = Eigen::Map<const Eigen::Vector3d>(params[1]);
    Eigen::Map<Eigen::Vector3d> res(residuals);
    res = (C * a_b - Eigen::Map<const Eigen::Vector3d>(params[2])) * inv_;
    if (jacobians == nullptr) return true;
    if (jacobians[0] != nullptr) {  // d(C Exp(e) a_b) = -C [a_b]x J_r(dtheta) de
      Eigen::Map<Eigen::Matrix<double, 3, 6, Eigen::RowMajor>> j(jacobians[0]);
      j.leftCols<3>().setZero();
      j.rightCols<3>() = -inv_ * C * Skew(a_b) * RightJacobianSO3(dtheta);
    }
    using Block3 = Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>;
    if (jacobians[1] != nullptr) Block3(jacobians[1], 3, 3) = inv_ * C;
    if (jacobians[2] != nullptr) Block3(jacobians[2], 3, 3) = -inv_ * Eigen::Matrix3d::Identity();
    return true;
  }

 private:
  const Eigen::Matrix3d C_ref_;
  const double inv_;
};

// A camera's calibrated mounting as a Gaussian prior: its total change from the given one
// (reference and perturbation), whitened by the calibration's covariance (sqrt_info: the
// inverse of its Cholesky factor, in the perturbation's coordinates). The rotation's change
// c = Log(Exp(dtheta) C_ref C_given^T) has d c / d dtheta = J_l(c)^-1 J_l(dtheta), with
// J_l(x) = J_r(-x) (common/rotation RightJacobianSO3).
class CameraPrior final : public ceres::SizedCostFunction<6, 6> {
 public:
  CameraPrior(const Eigen::Matrix3d& C_ref_given, const Eigen::Vector3d& r_ref_minus_given,
              const Eigen::Matrix<double, 6, 6>& sqrt_info)
      : C_ref_given_(C_ref_given), r_ref_minus_given_(r_ref_minus_given), sqrt_info_(sqrt_info) {}

  bool Evaluate(double const* const* params, double* residuals, double** jacobians) const override {
    const Eigen::Vector3d dtheta = Eigen::Map<const Eigen::Vector3d>(params[0]);
    Eigen::Matrix<double, 6, 1> change;
    change.head<3>() = LogSO3(ExpSO3(dtheta) * C_ref_given_);
    change.tail<3>() = r_ref_minus_given_ + Eigen::Map<const Eigen::Vector3d>(params[0] + 3);
    Eigen::Map<Eigen::Matrix<double, 6, 1>> res(residuals);
    res = sqrt_info_ * change;
    if (jacobians == nullptr || jacobians[0] == nullptr) return true;
    Eigen::Matrix<double, 6, 6> d_change = Eigen::Matrix<double, 6, 6>::Identity();
    d_change.topLeftCorner<3, 3>() =
        RightJacobianSO3(-change.head<3>()).inverse() * RightJacobianSO3(-dtheta);
    Eigen::Map<Eigen::Matrix<double, 6, 6, Eigen::RowMajor>> j(jacobians[0]);
    j = sqrt_info_ * d_change;
    return true;
  }

 private:
  const Eigen::Matrix3d C_ref_given_;  // C_k_b(reference) C_k_b(given)^T
  const Eigen::Vector3d r_ref_minus_given_;
  const Eigen::Matrix<double, 6, 6> sqrt_info_;
};

// The calibration's covariance of camera k's mounting in the perturbation's coordinates: the
// rig file's Euler-angle sigmas carried to dtheta_k through d dtheta / d euler (central
// differences), the position's as given. A zero sigma counts as 1e-9 (known exactly).
Eigen::Matrix<double, 6, 6> CalibrationCovariance6(const Rig& rig, int k) {
  const auto sk = static_cast<std::size_t>(k);
  const RigCameraSigma& sg = rig.sigma[sk];
  const Eigen::Matrix3d J = EulerToRotationJacobian(rig.cameras[sk].C_k_b);
  Eigen::Matrix<double, 6, 6> cov = Eigen::Matrix<double, 6, 6>::Zero();
  const Eigen::Vector3d se = sg.euler.cwiseMax(1e-9), sr = sg.r_b_bk.cwiseMax(1e-9);
  cov.topLeftCorner<3, 3>() = J * se.cwiseAbs2().asDiagonal() * J.transpose();
  cov.bottomRightCorner<3, 3>() = sr.cwiseAbs2().asDiagonal();
  return cov;
}

struct State {
  std::vector<BodyPose> ref;                        // per frame set
  std::vector<std::array<double, 6>> delta;         // per frame set
  std::vector<std::array<double, 3>> beacon;        // per rig beacon
  std::vector<bool> seen;                           // per rig beacon
  std::vector<RigCamera> cam_ref;                   // per rig camera
  std::vector<std::array<double, 6>> cam_delta;     // per rig camera (refine_cameras)
  std::vector<bool> cam_free;                       // per rig camera: refined
  std::vector<int> group;                           // per frame set: pivot group or -1
  std::vector<std::array<double, 6>> pivot;         // per pivot group: p_b, p_w
  std::vector<Eigen::Vector3d> pivot_b0;            // per pivot group: p_b's start
  std::vector<TurntablePlacement> placement;        // per pivot group (SurveyOptions::turntables)
  std::vector<std::array<double, 3>> axis_b, axis_w;  // per pivot group (placement's has_axis)
  std::vector<bool> pivot_solved;                   // per pivot group: in the problem (has observations)
};

void CheckInput(const Rig& rig, const std::vector<SurveyFrameSet>& sets) {
  if (!(rig.beacon_sigma > 0.0))
    throw UserError("survey: the rig has no beacon_sigma_mm: the surveyed map's 1-sigma is the prior");
  for (std::size_t i = 0; i < sets.size(); ++i)
    if (sets[i].pivot_group < -1 || sets[i].pivot_group >= static_cast<int>(sets.size()))
      throw UserError("survey: frame set " + std::to_string(i) + ": pivot group " +
                      std::to_string(sets[i].pivot_group) + " (-1 or 0 .. frame sets - 1)");
  for (std::size_t i = 0; i < sets.size(); ++i)
    for (const SurveyObservation& o : sets[i].observations)
      if (o.camera < 0 || o.camera >= rig.num_cameras || o.beacon < 0 || o.beacon >= rig.num_beacons ||
          !o.uv_px.allFinite())
        throw UserError("survey: frame set " + std::to_string(i) + ": an observation names camera " +
                        std::to_string(o.camera) + ", beacon " + std::to_string(o.beacon) + " (rig: " +
                        std::to_string(rig.num_cameras) + " cameras, " + std::to_string(rig.num_beacons) +
                        " beacons) or is not finite");
}

// Each pivot group's priors: p_b (the mount, else its start by 1 m), p_w (the surveyed centre);
// with the surveyed axis, each of its poses' axis term and the axis's prior.
void AddTurntableTerms(const SurveyOptions& o, State* s, ceres::Problem* problem) {
  using Prior6 = ceres::AutoDiffCostFunction<PointPrior, 3, 6>;
  for (std::size_t g = 0; g < s->pivot.size(); ++g) {
    double* pivot = s->pivot[g].data();
    if (!problem->HasParameterBlock(pivot)) continue;
    const TurntablePlacement& t = s->placement[g];
    problem->AddResidualBlock(t.has_centre_b ? new Prior6(new PointPrior{t.centre_b, 1.0 / t.centre_b_sigma_m, 0})
                                             : new Prior6(new PointPrior{s->pivot_b0[g], 1.0, 0}),
                              nullptr, pivot);
    if (t.has_centre)
      problem->AddResidualBlock(new Prior6(new PointPrior{t.centre_w, 1.0 / t.centre_sigma_m, 3}), nullptr, pivot);
    if (!t.has_axis) continue;
    for (std::size_t i = 0; i < s->group.size(); ++i)
      if (s->group[i] == static_cast<int>(g) && problem->HasParameterBlock(s->delta[i].data()))
        problem->AddResidualBlock(new TurntableAxisCost(s->ref[i].C_w_b, 1.0 / o.turntable_wobble_rad), nullptr,
                                  s->delta[i].data(), s->axis_b[g].data(), s->axis_w[g].data());
    problem->AddResidualBlock(
        new ceres::AutoDiffCostFunction<PointPrior, 3, 3>(new PointPrior{t.axis_w, 1.0 / t.axis_sigma_rad}), nullptr,
        s->axis_w[g].data());
    problem->SetManifold(s->axis_b[g].data(), new ceres::SphereManifold<3>());
    problem->SetManifold(s->axis_w[g].data(), new ceres::SphereManifold<3>());
  }
}

// Builds the problem at the current state with centroid sigma sigma_px.
void BuildProblem(const Rig& rig, const std::vector<SurveyFrameSet>& sets, const SurveyOptions& o,
                  double sigma_px, State* s, ceres::Problem* problem) {
  const double inv = 1.0 / sigma_px;
  for (std::size_t i = 0; i < sets.size(); ++i)
    for (const SurveyObservation& ob : sets[i].observations) {
      const auto k = static_cast<std::size_t>(ob.camera);
      ceres::LossFunction* loss = new ceres::HuberLoss(o.huber_sigmas);
      std::vector<double*> blocks{s->delta[i].data(), s->beacon[static_cast<std::size_t>(ob.beacon)].data()};
      const int g = s->group[i];
      if (g >= 0) blocks.push_back(s->pivot[static_cast<std::size_t>(g)].data());
      if (s->cam_free[k]) blocks.push_back(s->cam_delta[k].data());
      problem->AddResidualBlock(
          new BeaconImageCost(s->cam_ref[k], s->ref[i], ob.uv_px, inv, g >= 0, s->cam_free[k]), loss, blocks);
    }
  for (std::size_t i = 0; i < sets.size(); ++i)
    if (s->group[i] >= 0 && problem->HasParameterBlock(s->delta[i].data()))
      problem->SetManifold(s->delta[i].data(), new ceres::SubsetManifold(6, {0, 1, 2}));
  AddTurntableTerms(o, s, problem);
  for (int b = 0; b < rig.num_beacons; ++b) {
    if (!s->seen[static_cast<std::size_t>(b)]) continue;
    problem->AddResidualBlock(new ceres::AutoDiffCostFunction<PointPrior, 3, 3>(
                                  new PointPrior{rig.beacons_w[static_cast<std::size_t>(b)], 1.0 / rig.beacon_sigma}),
                              nullptr, s->beacon[static_cast<std::size_t>(b)].data());
  }
  if (!o.refine_cameras || !rig.has_sigma) return;
  for (int k = 0; k < rig.num_cameras; ++k) {
    const auto sk = static_cast<std::size_t>(k);
    if (!s->cam_free[sk]) continue;
    const Eigen::LLT<Eigen::Matrix<double, 6, 6>> llt(CalibrationCovariance6(rig, k));
    problem->AddResidualBlock(new CameraPrior(s->cam_ref[sk].C_k_b * rig.cameras[sk].C_k_b.transpose(),
                                              s->cam_ref[sk].r_b_bk - rig.cameras[sk].r_b_bk,
                                              llt.matrixL().solve(Eigen::Matrix<double, 6, 6>::Identity())),
                              nullptr, s->cam_delta[sk].data());
  }
}

// Folds each pose delta into its reference; returns the largest delta component.
double Relinearise(State* s) {
  double largest = 0.0;
  for (std::size_t i = 0; i < s->ref.size(); ++i) {
    const PoseDelta d = Eigen::Map<const PoseDelta>(s->delta[i].data());
    largest = std::max(largest, d.cwiseAbs().maxCoeff());
    s->ref[i] = Retract(s->ref[i], d);
    s->delta[i].fill(0.0);
    if (s->group[i] < 0) continue;
    s->ref[i].r_w_wb = PivotPosition(s->pivot[static_cast<std::size_t>(s->group[i])], s->ref[i].C_w_b);
  }
  for (std::size_t k = 0; k < s->cam_ref.size(); ++k) {
    const Eigen::Map<const Eigen::Matrix<double, 6, 1>> d(s->cam_delta[k].data());
    largest = std::max(largest, d.cwiseAbs().maxCoeff());
    s->cam_ref[k].C_k_b = ExpSO3(d.head<3>()) * s->cam_ref[k].C_k_b;
    s->cam_ref[k].r_b_bk += d.tail<3>();
    s->cam_delta[k].fill(0.0);
  }
  return largest;
}

// Residuals (px) of every observation at the current state, in input order.
std::vector<Eigen::Vector2d> ImageResiduals(const std::vector<SurveyFrameSet>& sets, const State& s) {
  std::vector<Eigen::Vector2d> r;
  for (std::size_t i = 0; i < sets.size(); ++i)
    for (const SurveyObservation& ob : sets[i].observations) {
      Eigen::Vector2d uv;
      const Eigen::Vector3d P = Eigen::Map<const Eigen::Vector3d>(s.beacon[static_cast<std::size_t>(ob.beacon)].data());
      if (ProjectBeacon(s.cam_ref[static_cast<std::size_t>(ob.camera)], s.ref[i], P, &uv) != ProjectStatus::kOk)
        uv.setConstant(1e9);
      r.push_back(uv - ob.uv_px);
    }
  return r;
}

// The centroid sigma from the inlier residuals (within huber_sigmas of the current sigma) over
// their degrees of freedom (2 per observation, less 6 per pose and 3 per beacon seen); false
// (nothing set) with too few observations to tell the noise from the fit.
bool EstimateSigmaPx(const std::vector<Eigen::Vector2d>& r, double sigma_px, int dof_taken, const SurveyOptions& o,
                     double* estimate) {
  double sum = 0.0;
  int n = 0;
  for (const Eigen::Vector2d& e : r)
    if (e.norm() <= o.huber_sigmas * sigma_px * std::sqrt(2.0)) {
      sum += e.squaredNorm();
      ++n;
    }
  const int dof = 2 * n - dof_taken;
  if (dof <= 0) return false;
  *estimate = std::sqrt(sum / dof);
  return true;
}

// SurveyOptions::check_gradients: every residual block's analytic Jacobians against central
// differences of step kStep in each coordinate of each parameter block (ambient: m, rad, the
// axes' unit vectors), at the problem's current values (Solve: before each solve and at its
// solution). A mismatch beyond kTolerance of the
// largest entry of its residual's row is a UserError naming the block. (Ceres's own check,
// Solver::Options::check_gradients, extrapolates Ridders' differences from steps of 0.32 m -
// 32 x max(0.01, 1 % of the value) - where a beacon 0.45 m from a turntable's camera is far from
// linear: on the demo's sweep it disagreed by 0.6 % with image Jacobians that central
// differences from 5.6 mm down to 0.1 um confirm to 1e-9, converging as h^2.)
void CheckJacobians(ceres::Problem* problem) {
  constexpr double kStep = 1e-6, kTolerance = 1e-5;
  std::vector<ceres::ResidualBlockId> ids;
  problem->GetResidualBlocks(&ids);
  for (std::size_t n = 0; n < ids.size(); ++n) {
    const ceres::CostFunction* f = problem->GetCostFunctionForResidualBlock(ids[n]);
    std::vector<double*> x;
    problem->GetParameterBlocksForResidualBlock(ids[n], &x);
    const auto m = static_cast<std::size_t>(f->num_residuals());
    const std::vector<std::int32_t>& sizes = f->parameter_block_sizes();
    std::vector<std::vector<double>> J(x.size());
    std::vector<double*> jp(x.size());
    for (std::size_t b = 0; b < x.size(); ++b) {
      J[b].assign(m * static_cast<std::size_t>(sizes[b]), 0.0);
      jp[b] = J[b].data();
    }
    std::vector<double> r(m), plus(m), minus(m), row_max(m, 1.0);
    if (!f->Evaluate(x.data(), r.data(), jp.data())) continue;  // (the solver's concern)
    for (std::size_t b = 0; b < x.size(); ++b)
      for (std::size_t i = 0; i < J[b].size(); ++i)
        row_max[i / static_cast<std::size_t>(sizes[b])] = std::max(row_max[i / static_cast<std::size_t>(sizes[b])], std::abs(J[b][i]));
    for (std::size_t b = 0; b < x.size(); ++b)
      for (std::int32_t c = 0; c < sizes[b]; ++c) {
        const double x0 = x[b][c];
        x[b][c] = x0 + kStep;
        const bool ok_plus = f->Evaluate(x.data(), plus.data(), nullptr);
        x[b][c] = x0 - kStep;
        const bool ok_minus = f->Evaluate(x.data(), minus.data(), nullptr);
        x[b][c] = x0;
        for (std::size_t i = 0; i < m && ok_plus && ok_minus; ++i) {
          const double numeric = (plus[i] - minus[i]) / (2.0 * kStep);
          const double analytic = J[b][i * static_cast<std::size_t>(sizes[b]) + static_cast<std::size_t>(c)];
          if (!(std::abs(analytic - numeric) <= kTolerance * row_max[i]))
            throw UserError("survey: check_gradients: residual block " + std::to_string(n) + ", parameter block " +
                            std::to_string(b) + " coordinate " + std::to_string(c) + ", residual " + std::to_string(i) +
                            ": analytic " + std::to_string(analytic) + ", central differences " + std::to_string(numeric));
        }
      }
  }
}

void Solve(const Rig& rig, const std::vector<SurveyFrameSet>& sets, const SurveyOptions& o, double sigma_px, State* s,
           std::ostream* progress, const std::string& label) {
  for (int pass = 0; pass < o.relinearise_passes; ++pass) {
    ceres::Problem problem;
    BuildProblem(rig, sets, o, sigma_px, s, &problem);
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::SPARSE_SCHUR;
    so.max_num_iterations = o.max_iterations;
    so.num_threads = o.threads;
    if (o.check_gradients) CheckJacobians(&problem);
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    if (summary.termination_type == ceres::FAILURE || !std::isfinite(summary.final_cost))
      throw UserError("survey: the adjustment failed: " + summary.message);
    // (Again at the solution, before it is folded into the references: with the perturbations
    // away from zero, which the right Jacobians' terms need to be tested.)
    if (o.check_gradients) CheckJacobians(&problem);
    const double moved = Relinearise(s);
    if (progress != nullptr)
      *progress << "survey: " << label << " solve " << pass + 1 << ": cost " << summary.initial_cost << " -> "
                << summary.final_cost << " in " << summary.iterations.size() << " iterations" << std::endl;
    if (moved < 1e-10) break;
  }
}

// Per-beacon outcome: refined position and covariance (unseen: the survey's), residuals, and
// the moved test against the surveyed position's own 1-sigma.
SurveyResult Summarise(const Rig& rig, const std::vector<SurveyFrameSet>& sets, const SurveyOptions& o,
                       const State& s, ceres::Covariance& cov, double sigma_px) {
  SurveyResult res;
  res.sigma_px = sigma_px;
  res.poses = s.ref;
  const double prior_var = rig.beacon_sigma * rig.beacon_sigma;
  res.beacons.resize(static_cast<std::size_t>(rig.num_beacons));
  std::vector<double> sum_sq(res.beacons.size(), 0.0);
  std::vector<std::uint64_t> last_set(res.beacons.size(), ~std::uint64_t{0});
  res.camera_rms_px.assign(static_cast<std::size_t>(rig.num_cameras), 0.0);
  res.camera_observations.assign(static_cast<std::size_t>(rig.num_cameras), 0);
  const std::vector<Eigen::Vector2d> r = ImageResiduals(sets, s);
  double total = 0.0;
  std::size_t k = 0;
  for (std::size_t i = 0; i < sets.size(); ++i)
    for (const SurveyObservation& ob : sets[i].observations) {
      const auto b = static_cast<std::size_t>(ob.beacon);
      const double e2 = r[k++].squaredNorm();
      sum_sq[b] += e2;
      total += e2;
      res.camera_rms_px[static_cast<std::size_t>(ob.camera)] += e2;
      ++res.camera_observations[static_cast<std::size_t>(ob.camera)];
      res.outliers += std::sqrt(e2) > o.huber_sigmas * sigma_px * std::sqrt(2.0) ? 1 : 0;
      ++res.beacons[b].observations;
      if (last_set[b] != i) ++res.beacons[b].frame_sets;
      last_set[b] = i;
    }
  res.observations = static_cast<int>(k);
  for (std::size_t c = 0; c < res.camera_rms_px.size(); ++c)
    if (res.camera_observations[c] > 0) res.camera_rms_px[c] = std::sqrt(res.camera_rms_px[c] / res.camera_observations[c]);
  res.rms_px = k > 0 ? std::sqrt(total / static_cast<double>(k)) : 0.0;
  res.pivots.resize(s.pivot.size());
  for (std::size_t g = 0; g < s.pivot.size(); ++g) {
    res.pivots[g].p_b = Eigen::Vector3d(s.pivot[g][0], s.pivot[g][1], s.pivot[g][2]);
    res.pivots[g].p_w = Eigen::Vector3d(s.pivot[g][3], s.pivot[g][4], s.pivot[g][5]);
    res.pivots[g].frame_sets = static_cast<int>(std::count(s.group.begin(), s.group.end(), static_cast<int>(g)));
    res.pivots[g].has_axis = s.placement[g].has_axis;
    if (res.pivots[g].has_axis) {
      res.pivots[g].axis_b = Eigen::Map<const Eigen::Vector3d>(s.axis_b[g].data());
      res.pivots[g].axis_w = Eigen::Map<const Eigen::Vector3d>(s.axis_w[g].data());
    }
    Eigen::Matrix<double, 6, 6, Eigen::RowMajor> m;
    if (s.pivot_solved[g] && cov.GetCovarianceBlock(s.pivot[g].data(), s.pivot[g].data(), m.data()))
      res.pivots[g].covariance = m;
  }
  res.cameras.resize(static_cast<std::size_t>(rig.num_cameras));
  for (std::size_t c = 0; c < res.cameras.size(); ++c) {
    SurveyCamera& sc = res.cameras[c];
    sc.C_k_b = s.cam_ref[c].C_k_b;
    sc.r_b_bk = s.cam_ref[c].r_b_bk;
    sc.rotation_change_rad = LogSO3(sc.C_k_b * rig.cameras[c].C_k_b.transpose());
    sc.translation_change_m = sc.r_b_bk - rig.cameras[c].r_b_bk;
    sc.refined = s.cam_free[c];
    sc.observations = res.camera_observations[c];
    if (sc.refined) {
      Eigen::Matrix<double, 6, 6, Eigen::RowMajor> m;
      cov.GetCovarianceBlock(s.cam_delta[c].data(), s.cam_delta[c].data(), m.data());
      sc.covariance = m;
    }
  }
  for (std::size_t b = 0; b < res.beacons.size(); ++b) {
    SurveyBeacon& sb = res.beacons[b];
    sb.surveyed_w = rig.beacons_w[b];
    sb.refined_w = Eigen::Map<const Eigen::Vector3d>(s.beacon[b].data());
    sb.covariance = prior_var * Eigen::Matrix3d::Identity();
    if (s.seen[b]) {
      Eigen::Matrix<double, 3, 3, Eigen::RowMajor> c;
      cov.GetCovarianceBlock(s.beacon[b].data(), s.beacon[b].data(), c.data());
      sb.covariance = c;
      sb.rms_px = std::sqrt(sum_sq[b] / sb.observations);
    }
    const Eigen::Vector3d d = sb.refined_w - sb.surveyed_w;
    sb.shift_sigmas = std::sqrt(d.squaredNorm() / prior_var);
    sb.moved = sb.shift_sigmas > o.moved_sigmas;
  }
  return res;
}

// The cameras' references (the given mountings) and which are refined: with refine_cameras,
// every camera that has observations; without the rig's calibration sigma as their prior, the
// first of them is held instead (it defines the body frame, which the others are refined in).
void SetUpCameras(const Rig& rig, const std::vector<SurveyFrameSet>& sets, const SurveyOptions& o, State* s) {
  const auto n = static_cast<std::size_t>(rig.num_cameras);
  s->cam_ref.assign(rig.cameras.begin(), rig.cameras.begin() + static_cast<std::ptrdiff_t>(n));
  s->cam_delta.assign(n, std::array<double, 6>{});
  s->cam_free.assign(n, false);
  if (!o.refine_cameras) return;
  for (const SurveyFrameSet& f : sets)
    for (const SurveyObservation& ob : f.observations) s->cam_free[static_cast<std::size_t>(ob.camera)] = true;
  if (rig.has_sigma) return;
  const auto gauge = std::find(s->cam_free.begin(), s->cam_free.end(), true);
  if (gauge != s->cam_free.end()) *gauge = false;
}

// Each pivot group's fixed point from its frame sets' poses: least squares of
// r_w_wb + C_w_b p_b = p_w over (p_b, p_w), a little ridge on p_b for runs about one axis; the
// group's poses then placed on it. Returns the number of groups.
int SetUpPivots(const std::vector<SurveyFrameSet>& sets, State* s) {
  int groups = 0;
  for (const SurveyFrameSet& f : sets) groups = std::max(groups, f.pivot_group + 1);
  s->group.clear();
  for (const SurveyFrameSet& f : sets) s->group.push_back(f.pivot_group);
  s->pivot.assign(static_cast<std::size_t>(groups), std::array<double, 6>{});
  s->pivot_b0.assign(static_cast<std::size_t>(groups), Eigen::Vector3d::Zero());
  for (int g = 0; g < groups; ++g) {
    Eigen::Matrix<double, 6, 6> AtA = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> Atb = Eigen::Matrix<double, 6, 1>::Zero();
    int n = 0;
    for (std::size_t i = 0; i < sets.size(); ++i) {
      if (s->group[i] != g) continue;
      Eigen::Matrix<double, 3, 6> A;
      A << s->ref[i].C_w_b, -Eigen::Matrix3d::Identity();
      AtA += A.transpose() * A;
      Atb -= A.transpose() * s->ref[i].r_w_wb;
      ++n;
    }
    if (n == 0) continue;
    AtA.topLeftCorner<3, 3>() += 1e-6 * n * Eigen::Matrix3d::Identity();
    const Eigen::Matrix<double, 6, 1> x = AtA.ldlt().solve(Atb);
    auto& pv = s->pivot[static_cast<std::size_t>(g)];
    for (int k = 0; k < 6; ++k) pv[static_cast<std::size_t>(k)] = x(k);
    s->pivot_b0[static_cast<std::size_t>(g)] = x.head<3>();
  }
  for (std::size_t i = 0; i < sets.size(); ++i) {
    if (s->group[i] < 0) continue;
    s->ref[i].r_w_wb = PivotPosition(s->pivot[static_cast<std::size_t>(s->group[i])], s->ref[i].C_w_b);
  }
  return groups;
}

// Each pivot group's placement (SurveyOptions::turntables) and, with a surveyed axis, the axis
// of its turn to start from: in the body, the axis of the relative rotation between its first
// pose and the one turned farthest from it (the surveyed axis carried into the body when it
// turns less than a degree); in the world, the first pose's image of it, signed as surveyed.
void SetUpAxes(const SurveyOptions& o, State* s) {
  const std::size_t groups = s->pivot.size();
  if (o.turntables.size() > groups)
    throw UserError("survey: a turntable placement for pivot group " + std::to_string(groups) +
                    ", which has no frame sets");
  s->placement.assign(groups, TurntablePlacement{});
  std::copy(o.turntables.begin(), o.turntables.end(), s->placement.begin());
  s->axis_b.assign(groups, std::array<double, 3>{});
  s->axis_w.assign(groups, std::array<double, 3>{});
  for (std::size_t g = 0; g < groups; ++g) {
    if (!s->placement[g].has_axis) continue;
    int first = -1;
    Eigen::Vector3d turn = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < s->group.size(); ++i) {
      if (s->group[i] != static_cast<int>(g)) continue;
      if (first < 0) first = static_cast<int>(i);
      const Eigen::Vector3d w = LogSO3(s->ref[static_cast<std::size_t>(first)].C_w_b.transpose() * s->ref[i].C_w_b);
      if (w.norm() > turn.norm()) turn = w;
    }
    if (first < 0) continue;  // (a group without frame sets: nothing to turn)
    const Eigen::Matrix3d& C0 = s->ref[static_cast<std::size_t>(first)].C_w_b;
    const Eigen::Vector3d& surveyed = s->placement[g].axis_w;
    Eigen::Vector3d a_b = turn.norm() > DegToRad(1.0) ? turn.normalized() : Eigen::Vector3d(C0.transpose() * surveyed);
    if ((C0 * a_b).dot(surveyed) < 0.0) a_b = -a_b;
    const Eigen::Vector3d a_w = C0 * a_b;
    for (int k = 0; k < 3; ++k) s->axis_b[g][static_cast<std::size_t>(k)] = a_b(k);
    for (int k = 0; k < 3; ++k) s->axis_w[g][static_cast<std::size_t>(k)] = a_w(k);
  }
}

// The degrees of freedom the adjustment takes from the image residuals: 6 per free pose, 3 per
// pivoted one and 6 per pivot group, 3 per beacon seen, 6 per refined camera; a pose turning
// about a surveyed axis keeps 1 of its attitude's 3, and the axis in the body and in the world
// take 2 each.
int DofTaken(const State& s, int groups) {
  const int seen = static_cast<int>(std::count(s.seen.begin(), s.seen.end(), true));
  const int free_cameras = static_cast<int>(std::count(s.cam_free.begin(), s.cam_free.end(), true));
  int pivoted = 0, on_axis = 0, axes = 0;
  for (const int g : s.group) {
    pivoted += g >= 0 ? 1 : 0;
    on_axis += g >= 0 && s.placement[static_cast<std::size_t>(g)].has_axis ? 1 : 0;
  }
  for (const TurntablePlacement& t : s.placement) axes += t.has_axis ? 1 : 0;
  return 6 * static_cast<int>(s.ref.size()) - 3 * pivoted + 6 * groups + 3 * seen + 6 * free_cameras - 2 * on_axis +
         4 * axes;
}

ceres::Covariance::Options CovarianceOptions(const SurveyOptions& o) {
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::SPARSE_QR;
  co.num_threads = o.threads;
  return co;
}

// The covariance of every seen beacon, refined camera and pivot group in the problem.
void ComputeCovariance(const Rig& rig, State* s, ceres::Problem* problem, ceres::Covariance* cov) {
  std::vector<std::pair<const double*, const double*>> blocks;
  for (int b = 0; b < rig.num_beacons; ++b)
    if (s->seen[static_cast<std::size_t>(b)])
      blocks.emplace_back(s->beacon[static_cast<std::size_t>(b)].data(), s->beacon[static_cast<std::size_t>(b)].data());
  for (std::size_t k = 0; k < s->cam_free.size(); ++k)
    if (s->cam_free[k]) blocks.emplace_back(s->cam_delta[k].data(), s->cam_delta[k].data());
  s->pivot_solved.assign(s->pivot.size(), false);
  for (std::size_t g = 0; g < s->pivot.size(); ++g) {
    s->pivot_solved[g] = problem->HasParameterBlock(s->pivot[g].data());
    if (s->pivot_solved[g]) blocks.emplace_back(s->pivot[g].data(), s->pivot[g].data());
  }
  if (!blocks.empty() && !cov->Compute(blocks, problem))
    throw UserError("survey: the covariance cannot be computed (a beacon seen from too few poses, or a camera's "
                    "mounting unobservable?)");
}

}  // namespace

Eigen::Matrix3d EulerToRotationJacobian(const Eigen::Matrix3d& C) {
  const EulerAngles e0 = MatrixToEuler(C);
  const Eigen::Matrix3d C0 = EulerToMatrix(e0);
  Eigen::Matrix3d J;
  const double h = 1e-6;
  for (int i = 0; i < 3; ++i) {
    EulerAngles ep = e0, em = e0;
    double* pp = i == 0 ? &ep.phi : i == 1 ? &ep.theta : &ep.psi;
    double* pm = i == 0 ? &em.phi : i == 1 ? &em.theta : &em.psi;
    *pp += h;
    *pm -= h;
    J.col(i) = (LogSO3(EulerToMatrix(ep) * C0.transpose()) - LogSO3(EulerToMatrix(em) * C0.transpose())) / (2 * h);
  }
  return J;
}

SurveyResult AdjustMap(const Rig& rig, const std::vector<SurveyFrameSet>& sets, const SurveyOptions& o,
                       std::ostream* progress) {
  const char* why = nullptr;
  if (!o.IsValid(&why)) throw UserError(std::string("survey: bad option ") + why);
  CheckInput(rig, sets);
  State s;
  s.delta.assign(sets.size(), std::array<double, 6>{});
  s.seen.assign(static_cast<std::size_t>(rig.num_beacons), false);
  for (const SurveyFrameSet& f : sets) {
    s.ref.push_back(f.pose);
    for (const SurveyObservation& ob : f.observations) s.seen[static_cast<std::size_t>(ob.beacon)] = true;
  }
  for (int b = 0; b < rig.num_beacons; ++b) {
    const Eigen::Vector3d& P = rig.beacons_w[static_cast<std::size_t>(b)];
    s.beacon.push_back({P.x(), P.y(), P.z()});
  }
  SetUpCameras(rig, sets, o, &s);
  const int groups = SetUpPivots(sets, &s);
  SetUpAxes(o, &s);
  const int dof_taken = DofTaken(s, groups);
  double sigma_px = o.start_sigma_px;
  bool estimated = true;
  for (int pass = 0; pass < o.reweight_passes; ++pass) {
    Solve(rig, sets, o, sigma_px, &s, progress, "pass " + std::to_string(pass + 1) + "/" + std::to_string(o.reweight_passes));
    double next = sigma_px;
    if (!EstimateSigmaPx(ImageResiduals(sets, s), sigma_px, dof_taken, o, &next)) {
      // The given sigma stands (SurveyResult::sigma_estimated false).
      if (progress != nullptr)
        *progress << "survey: too few observations to estimate the centroid sigma: " << sigma_px << " px kept" << std::endl;
      estimated = false;
      break;
    }
    if (progress != nullptr) *progress << "survey: centroid sigma " << sigma_px << " -> " << next << " px" << std::endl;
    const bool settled = std::abs(next - sigma_px) <= 0.02 * sigma_px;
    sigma_px = next;
    if (settled) break;
  }
  // The final problem at delta = 0 with the settled sigma: the covariance of the beacons.
  Solve(rig, sets, o, sigma_px, &s, progress, "final");
  ceres::Problem problem;
  BuildProblem(rig, sets, o, sigma_px, &s, &problem);
  ceres::Covariance cov(CovarianceOptions(o));
  ComputeCovariance(rig, &s, &problem, &cov);
  SurveyResult res = Summarise(rig, sets, o, s, cov, sigma_px);
  res.sigma_estimated = estimated;
  return res;
}

}  // namespace mfns::host
