#include "firmware/modules/solve/solve.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdint>

namespace mfns::fw {
namespace {

using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;


constexpr double kMaxLambda = 1e16;   // beyond this no step can lower the cost
constexpr double kGnRestartLambda = 1e-6;
constexpr double kCostFloorPx2 = 1e-30;  // an exact fit: nothing left to improve

// The observations a solve works on, and which of them are in.
struct Problem {
  const Rig* rig;
  const BlobObs* blobs;
  const Match* matches;
  int n;
  const std::array<bool, limits::kMaxMatches>* active;
  const std::array<double, limits::kMaxMatches>* weight;  // per match (BeaconWeights); null: all 1
};

double WeightOf(const Problem& p, int i) {
  return p.weight != nullptr ? (*p.weight)[static_cast<std::size_t>(i)] : 1.0;
}

// rho(s) and the IRLS weight rho'(s) / s of the 2-D residual norm s.
void Loss(RobustLoss loss, double k, double s, double* rho, double* w) {
  switch (loss) {
    case RobustLoss::kHuber:
      if (s <= k) {
        *rho = 0.5 * s * s;
        *w = 1.0;
      } else {
        *rho = k * s - 0.5 * k * k;
        *w = k / s;
      }
      return;
    case RobustLoss::kCauchy: {
      const double q = s * s / (k * k);
      *rho = 0.5 * k * k * std::log1p(q);
      *w = 1.0 / (1.0 + q);
      return;
    }
    case RobustLoss::kNone:
      break;
  }
  *rho = 0.5 * s * s;
  *w = 1.0;
}

const Eigen::Vector3d& BeaconOf(const Problem& p, int i) {
  return p.rig->beacons_w[static_cast<std::size_t>(p.matches[i].beacon)];
}
const RigCamera& CameraOf(const Problem& p, int i) {
  return p.rig->cameras[static_cast<std::size_t>(p.matches[i].camera)];
}
const Eigen::Vector2d& MeasuredOf(const Problem& p, int i) {
  return p.blobs[p.matches[i].blob].uv_px;
}

// Robust cost at `pose` and, when H is given, the IRLS normal equations H delta = g.
// False when an active observation cannot be projected (behind its camera, non-finite).
bool Evaluate(const Problem& p, const BodyPose& pose, RobustLoss loss, double k, double* cost,
              Mat6* H, Vec6* g) {
  *cost = 0.0;
  if (H != nullptr) {
    H->setZero();
    g->setZero();
  }
  for (int i = 0; i < p.n; ++i) {
    if (!(*p.active)[static_cast<std::size_t>(i)]) continue;
    Eigen::Vector2d uv;
    Eigen::Matrix<double, 2, 6> J;
    if (ProjectBeacon(CameraOf(p, i), pose, BeaconOf(p, i), &uv, H != nullptr ? &J : nullptr) !=
        ProjectStatus::kOk)
      return false;
    const Eigen::Vector2d r = MeasuredOf(p, i) - uv;
    double rho = 0.0, w = 1.0;
    Loss(loss, k, r.norm(), &rho, &w);
    const double wi = WeightOf(p, i);
    *cost += wi * rho;
    w *= wi;
    if (H != nullptr) {
      H->noalias() += w * J.transpose() * J;
      g->noalias() += w * J.transpose() * r;
    }
  }
  return std::isfinite(*cost) && (H == nullptr || (H->allFinite() && g->allFinite()));
}

enum class RunOutcome : unsigned char { kConverged, kIterationBound, kDiverged, kNotProjectable };

// One Levenberg-Marquardt run over the active observations, from *pose.
RunOutcome RunLm(const Problem& p, RobustLoss loss, const SolveOptions& o, const BodyPose& start,
                 BodyPose* pose, int* iterations) {
  double cost = 0.0;
  Mat6 H;
  Vec6 g;
  if (!Evaluate(p, *pose, loss, o.loss_scale_px, &cost, &H, &g)) return RunOutcome::kNotProjectable;
  double lambda = o.initial_lambda;
  for (int it = 0; it < o.max_iterations; ++it) {
    ++*iterations;
    if (cost <= kCostFloorPx2) return RunOutcome::kConverged;
    Mat6 A = H;
    // Damping relative to the diagonal (scale-free across metres and radians), plus a tiny
    // absolute term so an all-zero column (unobservable direction) still gives a finite step.
    for (int j = 0; j < 6; ++j) A(j, j) += lambda * H(j, j) + 1e-12 * (lambda > 0.0 ? 1.0 : 0.0);
    const Eigen::LDLT<Mat6> ldlt(A);
    const Vec6 delta = ldlt.solve(g);
    double trial_cost = 0.0;
    Mat6 Ht;
    Vec6 gt;
    bool accepted = false;
    BodyPose trial;
    if (ldlt.info() == Eigen::Success && delta.allFinite()) {
      trial = Retract(*pose, delta);
      accepted = Evaluate(p, trial, loss, o.loss_scale_px, &trial_cost, &Ht, &gt) &&
                 trial_cost <= cost;
    }
    if (accepted) {
      const double decrease = cost - trial_cost;
      *pose = trial;
      cost = trial_cost;
      H = Ht;
      g = gt;
      lambda *= 0.1;
      if ((pose->r_w_wb - start.r_w_wb).norm() > o.max_travel_m) return RunOutcome::kDiverged;
      if (delta.norm() < o.step_tol || decrease <= o.cost_tol * (cost + decrease))
        return RunOutcome::kConverged;
      continue;
    }
    // Rejected: a step this small cannot be improved on in double precision.
    if (delta.allFinite() && delta.norm() < o.step_tol) return RunOutcome::kConverged;
    lambda = lambda > 0.0 ? lambda * 10.0 : kGnRestartLambda;
    if (lambda > kMaxLambda) return RunOutcome::kConverged;
  }
  return RunOutcome::kIterationBound;
}

BeaconSet ActiveBeacons(const Problem& p) {
  BeaconSet set;
  for (int i = 0; i < p.n; ++i)
    if ((*p.active)[static_cast<std::size_t>(i)]) set.Set(p.matches[i].beacon);
  return set;
}

// Residual norms of every match at `pose` (-1 when not projectable); returns the active one
// with the largest weighted residual sqrt(w) |r| (-1 if none).
int Residuals(const Problem& p, const BodyPose& pose, SolveResult* res) {
  int worst = -1;
  double worst_weighted = 0.0;
  for (int i = 0; i < p.n; ++i) {
    const auto si = static_cast<std::size_t>(i);
    Eigen::Vector2d uv;
    res->residual_px[si] = ProjectBeacon(CameraOf(p, i), pose, BeaconOf(p, i), &uv) == ProjectStatus::kOk
                               ? (MeasuredOf(p, i) - uv).norm()
                               : -1.0;
    if (!(*p.active)[si]) continue;
    const double weighted = res->residual_px[si] * std::sqrt(WeightOf(p, i));
    if (worst < 0 || weighted > worst_weighted || res->residual_px[si] < 0.0) {
      worst = i;
      worst_weighted = res->residual_px[si] < 0.0 ? 1e300 : weighted;
    }
  }
  return worst;
}

SolveStatus CheckInputs(const Rig& rig, const BlobObs* blobs, int num_blobs, const Match* matches,
                        int num_matches, const BodyPose& initial, const SolveOptions& o) {
  if (!o.IsValid()) return SolveStatus::kBadInput;
  if (num_matches < 0 || num_matches > limits::kMaxMatches || num_blobs < 0 ||
      num_blobs > limits::kMaxObservations || (num_matches > 0 && (matches == nullptr || blobs == nullptr)))
    return SolveStatus::kBadInput;
  if (rig.num_cameras <= 0 || rig.num_cameras > limits::kMaxCameras || rig.num_beacons < 0 ||
      rig.num_beacons > limits::kMaxBeacons)
    return SolveStatus::kBadInput;
  if (!initial.C_w_b.allFinite() || !initial.r_w_wb.allFinite()) return SolveStatus::kNonFinite;
  std::array<BeaconSet, limits::kMaxCameras> seen{};  // beacons per camera
  std::array<bool, limits::kMaxObservations> used{};      // blobs
  for (int i = 0; i < num_matches; ++i) {
    const Match& m = matches[i];
    if (m.blob < 0 || m.blob >= num_blobs || m.beacon < 0 || m.beacon >= rig.num_beacons ||
        m.camera < 0 || m.camera >= rig.num_cameras || blobs[m.blob].camera != m.camera)
      return SolveStatus::kBadInput;
    auto& cam_set = seen[static_cast<std::size_t>(m.camera)];
    if (cam_set.Has(m.beacon) || used[static_cast<std::size_t>(m.blob)]) return SolveStatus::kBadInput;
    cam_set.Set(m.beacon);
    used[static_cast<std::size_t>(m.blob)] = true;
    if (!blobs[m.blob].uv_px.allFinite() ||
        !rig.beacons_w[static_cast<std::size_t>(m.beacon)].allFinite())
      return SolveStatus::kNonFinite;
  }
  return SolveStatus::kOk;
}

// Statistics and covariance over the inliers at the final pose.
SolveStatus Finish(const Problem& p, const SolveOptions& o, SolveResult* res) {
  res->num_inliers = 0;
  res->inliers_per_camera.fill(0);
  double sum2 = 0.0;
  res->max_residual_px = 0.0;
  Mat6 H = Mat6::Zero();
  for (int i = 0; i < p.n; ++i) {
    const auto si = static_cast<std::size_t>(i);
    res->inlier[si] = (*p.active)[si];
    if (!res->inlier[si]) continue;
    Eigen::Vector2d uv;
    Eigen::Matrix<double, 2, 6> J;
    if (ProjectBeacon(CameraOf(p, i), res->pose, BeaconOf(p, i), &uv, &J) != ProjectStatus::kOk)
      return SolveStatus::kNonFinite;  // cannot happen: every run ends at a projectable pose
    const double s = (MeasuredOf(p, i) - uv).norm() * std::sqrt(WeightOf(p, i));
    sum2 += s * s;
    res->max_residual_px = std::max(res->max_residual_px, s);
    H.noalias() += WeightOf(p, i) * J.transpose() * J;
    ++res->num_inliers;
    ++res->inliers_per_camera[static_cast<std::size_t>(p.matches[i].camera)];
  }
  res->num_beacons = ActiveBeacons(p).Count();
  res->cost = 0.5 * sum2;
  res->rms_px = res->num_inliers > 0 ? std::sqrt(sum2 / res->num_inliers) : 0.0;
  if (!H.allFinite() || !res->pose.C_w_b.allFinite() || !res->pose.r_w_wb.allFinite())
    return SolveStatus::kNonFinite;
  // Rank test on the Jacobi-scaled information (metres and radians made comparable).
  Vec6 d;
  for (int j = 0; j < 6; ++j) {
    if (!(H(j, j) > 0.0)) return SolveStatus::kSingular;
    d[j] = 1.0 / std::sqrt(H(j, j));
  }
  const Mat6 Hs = d.asDiagonal() * H * d.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Mat6> eig(Hs, Eigen::EigenvaluesOnly);
  if (eig.info() != Eigen::Success) return SolveStatus::kNonFinite;
  const Vec6 ev = eig.eigenvalues();
  res->rcond = ev[5] > 0.0 ? ev[0] / ev[5] : 0.0;
  if (!(res->rcond >= o.min_rcond)) return SolveStatus::kSingular;
  // sigma^2 (J^T J)^-1 = D (D H D)^-1 D sigma^2, through the better-conditioned scaled matrix.
  const Eigen::LDLT<Mat6> ldlt(Hs);
  const Mat6 Hs_inv = ldlt.solve(Mat6::Identity());
  res->covariance = o.sigma_px * o.sigma_px * (d.asDiagonal() * Hs_inv * d.asDiagonal());
  res->covariance = 0.5 * (res->covariance + res->covariance.transpose()).eval();
  res->has_covariance = res->covariance.allFinite();
  return res->has_covariance ? SolveStatus::kOk : SolveStatus::kNonFinite;
}

SolveStatus FromRun(RunOutcome r) {
  switch (r) {
    case RunOutcome::kConverged: return SolveStatus::kOk;
    case RunOutcome::kIterationBound: return SolveStatus::kNotConverged;
    case RunOutcome::kDiverged: return SolveStatus::kDiverged;
    case RunOutcome::kNotProjectable: return SolveStatus::kBehindCamera;
  }
  return SolveStatus::kNonFinite;
}

SolveStatus Solve(const Problem& p, std::array<bool, limits::kMaxMatches>* active,
                  const BodyPose& initial, const SolveOptions& o, SolveResult* res) {
  if (ActiveBeacons(p).Count() < o.min_beacons) return SolveStatus::kTooFewObservations;
  bool not_converged = false;
  RunOutcome run = RunLm(p, o.loss, o, initial, &res->pose, &res->iterations);
  if (run == RunOutcome::kNotProjectable) {
    // Only the initial pose can be unprojectable (trial steps that are get rejected).
    for (int i = 0; i < p.n; ++i) {
      Eigen::Vector2d uv;
      if (ProjectBeacon(CameraOf(p, i), initial, BeaconOf(p, i), &uv) == ProjectStatus::kNonFinite)
        return SolveStatus::kNonFinite;
    }
    return SolveStatus::kBehindCamera;
  }
  if (run == RunOutcome::kDiverged) return SolveStatus::kDiverged;
  not_converged = run == RunOutcome::kIterationBound;

  // Outlier rejection: drop the worst, re-solve, until every residual is under the threshold.
  if (o.outlier_threshold_px > 0.0) {
    for (int round = 0;; ++round) {
      const int worst = Residuals(p, res->pose, res);
      if (worst < 0) return SolveStatus::kTooFewObservations;
      const double s = res->residual_px[static_cast<std::size_t>(worst)] * std::sqrt(WeightOf(p, worst));
      if (s >= 0.0 && s <= o.outlier_threshold_px) break;
      if (round >= o.max_outlier_rounds) return SolveStatus::kTooManyOutliers;
      (*active)[static_cast<std::size_t>(worst)] = false;
      ++res->outlier_rounds;
      if (ActiveBeacons(p).Count() < o.min_beacons) return SolveStatus::kTooFewObservations;
      run = RunLm(p, o.loss, o, initial, &res->pose, &res->iterations);
      if (run != RunOutcome::kConverged && run != RunOutcome::kIterationBound) return FromRun(run);
      not_converged = run == RunOutcome::kIterationBound;
    }
  }
  if (o.final_least_squares && o.loss != RobustLoss::kNone) {
    run = RunLm(p, RobustLoss::kNone, o, initial, &res->pose, &res->iterations);
    if (run != RunOutcome::kConverged && run != RunOutcome::kIterationBound) return FromRun(run);
    not_converged = run == RunOutcome::kIterationBound;
  }
  Residuals(p, res->pose, res);
  const SolveStatus fin = Finish(p, o, res);
  if (fin != SolveStatus::kOk) return fin;
  return not_converged ? SolveStatus::kNotConverged : SolveStatus::kOk;
}

}  // namespace

bool BeaconWeights(const Rig& rig, const Match* matches, int num_matches, const SolveOptions& o,
                   std::array<double, limits::kMaxMatches>* weight) {
  if (!rig.has_beacon_sigmas || !(o.beacon_px_per_m > 0.0)) return false;
  const double s2 = o.sigma_px * o.sigma_px;
  const double ref = o.beacon_px_per_m * rig.beacon_sigma;
  for (int i = 0; i < num_matches; ++i) {
    const double m = o.beacon_px_per_m * rig.beacon_sigmas[static_cast<std::size_t>(matches[i].beacon)];
    (*weight)[static_cast<std::size_t>(i)] = (s2 + ref * ref) / (s2 + m * m);
  }
  return true;
}

const char* ToString(SolveStatus s) {
  switch (s) {
    case SolveStatus::kOk: return "ok";
    case SolveStatus::kTooFewObservations: return "fewer beacons than needed (3 give 6 equations for 6 unknowns)";
    case SolveStatus::kNotConverged: return "iteration bound reached before convergence";
    case SolveStatus::kDiverged: return "estimate moved farther than max_travel_m";
    case SolveStatus::kSingular: return "geometry does not determine the pose (rank-deficient J^T J)";
    case SolveStatus::kNonFinite: return "NaN or infinite value";
    case SolveStatus::kBadInput: return "bad options or observation indices";
    case SolveStatus::kBehindCamera: return "an observed beacon is behind its camera at the initial pose";
    case SolveStatus::kTooManyOutliers: return "outliers remain after the rejection rounds";
  }
  return "unknown solve status";
}

const char* ToString(RobustLoss l) {
  switch (l) {
    case RobustLoss::kNone: return "none";
    case RobustLoss::kHuber: return "huber";
    case RobustLoss::kCauchy: return "cauchy";
  }
  return "unknown loss";
}

bool SolveOptions::IsValid(const char** why) const {
  const char* bad = nullptr;
  if (loss != RobustLoss::kNone && loss != RobustLoss::kHuber && loss != RobustLoss::kCauchy)
    bad = "loss";
  else if (!(loss_scale_px > 0.0) || !std::isfinite(loss_scale_px)) bad = "loss_scale_px";
  else if (!(sigma_px > 0.0) || !std::isfinite(sigma_px)) bad = "sigma_px";
  else if (max_iterations < 1 || max_iterations > limits::kMaxSolverIterations) bad = "max_iterations";
  else if (!(step_tol >= 0.0) || !std::isfinite(step_tol)) bad = "step_tol";
  else if (!(cost_tol >= 0.0) || !(cost_tol < 1.0)) bad = "cost_tol";
  else if (!(initial_lambda >= 0.0) || !(initial_lambda < kMaxLambda)) bad = "initial_lambda";
  else if (!std::isfinite(outlier_threshold_px)) bad = "outlier_threshold_px";
  else if (max_outlier_rounds < 0 || max_outlier_rounds > limits::kMaxOutlierRounds) bad = "max_outlier_rounds";
  else if (min_beacons < 3 || min_beacons > limits::kMaxBeacons) bad = "min_beacons";
  else if (!(max_travel_m > 0.0)) bad = "max_travel_m";
  else if (!(min_rcond > 0.0) || !(min_rcond < 1.0)) bad = "min_rcond";
  else if (!(beacon_px_per_m >= 0.0) || !std::isfinite(beacon_px_per_m)) bad = "beacon_px_per_m";
  if (why != nullptr) *why = bad != nullptr ? bad : "ok";
  return bad == nullptr;
}

SolveStatus SolvePose(const Rig& rig, const BlobObs* blobs, int num_blobs, const Match* matches,
                      int num_matches, const BodyPose& initial, const SolveOptions& options,
                      SolveResult* result) {
  SolveResult& res = *result;
  res.pose = initial;
  res.covariance.setZero();
  res.has_covariance = false;
  res.rcond = 0.0;
  res.iterations = 0;
  res.outlier_rounds = 0;
  res.num_inliers = 0;
  res.num_beacons = 0;
  res.inliers_per_camera.fill(0);
  res.rms_px = res.max_residual_px = res.cost = 0.0;
  res.residual_px.fill(-1.0);
  res.inlier.fill(false);
  res.status = CheckInputs(rig, blobs, num_blobs, matches, num_matches, initial, options);
  if (res.status != SolveStatus::kOk) return res.status;
  std::array<bool, limits::kMaxMatches> active{};
  for (int i = 0; i < num_matches; ++i) active[static_cast<std::size_t>(i)] = true;
  std::array<double, limits::kMaxMatches> weight;
  const bool weighted = BeaconWeights(rig, matches, num_matches, options, &weight);
  const Problem p{&rig, blobs, matches, num_matches, &active, weighted ? &weight : nullptr};
  res.status = Solve(p, &active, initial, options, &res);
  if (res.status != SolveStatus::kOk && res.status != SolveStatus::kNotConverged) {
    for (int i = 0; i < num_matches; ++i) res.inlier[static_cast<std::size_t>(i)] = active[static_cast<std::size_t>(i)];
  }
  return res.status;
}

void SolveCounters::Record(const SolveResult& r) {
  const auto i = static_cast<std::size_t>(r.status);
  if (i < by_status.size()) ++by_status[i];
  outliers_rejected += static_cast<std::uint32_t>(r.outlier_rounds);
}

}  // namespace mfns::fw
