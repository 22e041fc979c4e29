#include "host/calib/survey/survey.h"

#include <ceres/ceres.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <memory>
#include <ostream>
#include <string>

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
  if (why != nullptr) *why = bad;
  return bad == nullptr;
}

namespace {

// The image of a beacon through the navigation model (common/rig ProjectBeacon, eq. 2) at the
// pose Retract(ref, delta). The parameter is the pose perturbation of rig.h from a reference
// pose held outside Ceres; its Jacobian is the model's perturbation Jacobian, exact at
// delta = 0: the solve is repeated with each delta folded into its reference until the deltas
// vanish (so the optimum and the covariance, taken at delta = 0, are exact).
class BeaconImageCost final : public ceres::SizedCostFunction<2, 6, 3> {
 public:
  BeaconImageCost(const RigCamera& cam, const BodyPose* ref, const Eigen::Vector2d& uv, double inv_sigma)
      : cam_(cam), ref_(ref), uv_(uv), inv_sigma_(inv_sigma) {}

  bool Evaluate(double const* const* params, double* residuals, double** jacobians) const override {
    const PoseDelta delta = Eigen::Map<const PoseDelta>(params[0]);
    const Eigen::Vector3d P_w = Eigen::Map<const Eigen::Vector3d>(params[1]);
    Eigen::Vector2d uv;
    Eigen::Matrix<double, 2, 6> J_pose;
    Eigen::Matrix<double, 2, 3> J_P;
    if (ProjectBeacon(cam_, Retract(*ref_, delta), P_w, &uv, &J_pose, &J_P) != ProjectStatus::kOk) return false;
    Eigen::Map<Eigen::Vector2d> res(residuals);
    res = (uv - uv_) * inv_sigma_;
    if (jacobians != nullptr && jacobians[0] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 2, 6, Eigen::RowMajor>> j(jacobians[0]);
      j = J_pose * inv_sigma_;
    }
    if (jacobians != nullptr && jacobians[1] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> j(jacobians[1]);
      j = J_P * inv_sigma_;
    }
    return true;
  }

 private:
  const RigCamera cam_;
  const BodyPose* ref_;
  const Eigen::Vector2d uv_;
  const double inv_sigma_;
};

// The surveyed position as a Gaussian prior of 1-sigma sigma_m per coordinate.
struct BeaconPrior {
  Eigen::Vector3d P0;
  double inv_sigma;
  template <typename T>
  bool operator()(const T* P, T* res) const {
    for (int i = 0; i < 3; ++i) res[i] = (P[i] - T(P0(i))) * T(inv_sigma);
    return true;
  }
};

struct State {
  std::vector<BodyPose> ref;                        // per frame set
  std::vector<std::array<double, 6>> delta;         // per frame set
  std::vector<std::array<double, 3>> beacon;        // per rig beacon
  std::vector<bool> seen;                           // per rig beacon
};

void CheckInput(const Rig& rig, const std::vector<SurveyFrameSet>& sets) {
  if (!(rig.beacon_sigma > 0.0))
    throw UserError("survey: the rig has no beacon_sigma_mm: the surveyed map's 1-sigma is the prior");
  for (std::size_t i = 0; i < sets.size(); ++i)
    for (const SurveyObservation& o : sets[i].observations)
      if (o.camera < 0 || o.camera >= rig.num_cameras || o.beacon < 0 || o.beacon >= rig.num_beacons ||
          !o.uv_px.allFinite())
        throw UserError("survey: frame set " + std::to_string(i) + ": an observation names camera " +
                        std::to_string(o.camera) + ", beacon " + std::to_string(o.beacon) + " (rig: " +
                        std::to_string(rig.num_cameras) + " cameras, " + std::to_string(rig.num_beacons) +
                        " beacons) or is not finite");
}

// Builds the problem at the current state with centroid sigma sigma_px.
void BuildProblem(const Rig& rig, const std::vector<SurveyFrameSet>& sets, const SurveyOptions& o,
                  double sigma_px, State* s, ceres::Problem* problem) {
  const double inv = 1.0 / sigma_px;
  for (std::size_t i = 0; i < sets.size(); ++i)
    for (const SurveyObservation& ob : sets[i].observations) {
      ceres::LossFunction* loss = new ceres::HuberLoss(o.huber_sigmas);
      problem->AddResidualBlock(
          new BeaconImageCost(rig.cameras[static_cast<std::size_t>(ob.camera)], &s->ref[i], ob.uv_px, inv), loss,
          s->delta[i].data(), s->beacon[static_cast<std::size_t>(ob.beacon)].data());
    }
  for (int b = 0; b < rig.num_beacons; ++b) {
    if (!s->seen[static_cast<std::size_t>(b)]) continue;
    problem->AddResidualBlock(new ceres::AutoDiffCostFunction<BeaconPrior, 3, 3>(
                                  new BeaconPrior{rig.beacons_w[static_cast<std::size_t>(b)], 1.0 / rig.beacon_sigma}),
                              nullptr, s->beacon[static_cast<std::size_t>(b)].data());
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
  }
  return largest;
}

// Residuals (px) of every observation at the current state, in input order.
std::vector<Eigen::Vector2d> ImageResiduals(const Rig& rig, const std::vector<SurveyFrameSet>& sets, const State& s) {
  std::vector<Eigen::Vector2d> r;
  for (std::size_t i = 0; i < sets.size(); ++i)
    for (const SurveyObservation& ob : sets[i].observations) {
      Eigen::Vector2d uv;
      const Eigen::Vector3d P = Eigen::Map<const Eigen::Vector3d>(s.beacon[static_cast<std::size_t>(ob.beacon)].data());
      if (ProjectBeacon(rig.cameras[static_cast<std::size_t>(ob.camera)], s.ref[i], P, &uv) != ProjectStatus::kOk)
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

void Solve(const Rig& rig, const std::vector<SurveyFrameSet>& sets, const SurveyOptions& o, double sigma_px, State* s,
           std::ostream* progress, const std::string& label) {
  for (int pass = 0; pass < o.relinearise_passes; ++pass) {
    ceres::Problem problem;
    BuildProblem(rig, sets, o, sigma_px, s, &problem);
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::SPARSE_SCHUR;
    so.max_num_iterations = o.max_iterations;
    so.num_threads = o.threads;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    if (summary.termination_type == ceres::FAILURE || !std::isfinite(summary.final_cost))
      throw UserError("survey: the adjustment failed: " + summary.message);
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
  const std::vector<Eigen::Vector2d> r = ImageResiduals(rig, sets, s);
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

}  // namespace

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
  const int seen = static_cast<int>(std::count(s.seen.begin(), s.seen.end(), true));
  const int dof_taken = 6 * static_cast<int>(sets.size()) + 3 * seen;
  double sigma_px = o.start_sigma_px;
  bool estimated = true;
  for (int pass = 0; pass < o.reweight_passes; ++pass) {
    Solve(rig, sets, o, sigma_px, &s, progress, "pass " + std::to_string(pass + 1) + "/" + std::to_string(o.reweight_passes));
    double next = sigma_px;
    if (!EstimateSigmaPx(ImageResiduals(rig, sets, s), sigma_px, dof_taken, o, &next)) {
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
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::SPARSE_QR;
  co.num_threads = o.threads;
  ceres::Covariance cov(co);
  std::vector<std::pair<const double*, const double*>> blocks;
  for (int b = 0; b < rig.num_beacons; ++b)
    if (s.seen[static_cast<std::size_t>(b)]) blocks.emplace_back(s.beacon[static_cast<std::size_t>(b)].data(),
                                                                 s.beacon[static_cast<std::size_t>(b)].data());
  if (!blocks.empty() && !cov.Compute(blocks, &problem))
    throw UserError("survey: the beacons' covariance cannot be computed (a beacon seen from too few poses?)");
  SurveyResult res = Summarise(rig, sets, o, s, cov, sigma_px);
  res.sigma_estimated = estimated;
  return res;
}

}  // namespace mfns::host
