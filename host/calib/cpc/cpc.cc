#include "host/calib/cpc/cpc.h"

#include <Eigen/Dense>
#include <cmath>
#include <sstream>

#include "common/rotation/rotation.h"
#include "host/calib/ml/joint.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

// Row-major element index of (r, c), 0-based.
constexpr int El(int r, int c) { return 3 * r + c; }

// A10's rows: Omega images (3,1) (3,2) (1,3) (2,3); omega images (1,2) (1,3) (2,1) (3,1).
constexpr int kOmegaRows[4] = {El(2, 0), El(2, 1), El(0, 2), El(1, 2)};
constexpr int kAuxRows[4] = {El(0, 1), El(0, 2), El(1, 0), El(2, 0)};

struct Lsq {
  Eigen::VectorXd x;
  Eigen::MatrixXd cov;
  double rms = 0;
};

Lsq SolveLsq(const std::vector<Eigen::RowVectorXd>& rows, const std::vector<double>& rhs, int n) {
  Eigen::MatrixXd A(static_cast<int>(rows.size()), n);
  Eigen::VectorXd b(static_cast<int>(rows.size()));
  for (std::size_t i = 0; i < rows.size(); ++i) {
    A.row(static_cast<int>(i)) = rows[i];
    b[static_cast<int>(i)] = rhs[i];
  }
  Lsq s;
  s.x = A.colPivHouseholderQr().solve(b);
  const int m = static_cast<int>(rows.size());
  const double r2 = (A * s.x - b).squaredNorm();
  s.rms = std::sqrt(r2 / m);
  const double var = m > n ? r2 / (m - n) : 0.0;
  s.cov = var * (A.transpose() * A).inverse();
  return s;
}

Eigen::Vector3d Sqrt3(const Eigen::Matrix3d& c) { return c.diagonal().cwiseMax(0.0).cwiseSqrt(); }

// Mean of per-image rotations (chordal) and the sigma of the mean from their scatter about it
// (small rotations in the frame the rotations map into).
void MeanRotation(const std::vector<Eigen::Matrix3d>& Cs, Eigen::Matrix3d* mean, Eigen::Matrix3d* cov_mean) {
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  for (const Eigen::Matrix3d& C : Cs) sum += C;
  *mean = NearestRotation(sum);
  Eigen::Matrix3d s = Eigen::Matrix3d::Zero();
  for (const Eigen::Matrix3d& C : Cs) {
    const Eigen::Vector3d phi = LogSO3(C * mean->transpose());
    s += phi * phi.transpose();
  }
  const double n = static_cast<double>(Cs.size());
  *cov_mean = n > 1 ? Eigen::Matrix3d(s / (n - 1) / n) : Eigen::Matrix3d::Zero();
}

void MeanVector(const std::vector<Eigen::Vector3d>& vs, Eigen::Vector3d* mean, Eigen::Vector3d* sigma_mean) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& v : vs) sum += v;
  const double n = static_cast<double>(vs.size());
  *mean = sum / n;
  Eigen::Vector3d s = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& v : vs) s += (v - *mean).cwiseAbs2();
  *sigma_mean = n > 1 ? Eigen::Vector3d((s / (n - 1) / n).cwiseSqrt()) : Eigen::Vector3d::Zero();
}

}  // namespace

Eigen::Matrix<double, 9, 6> SmallAngleDesign(const Eigen::Matrix3d& N) {
  Eigen::Matrix<double, 9, 6> D;
  for (int j = 0; j < 6; ++j) {
    const Eigen::Vector3d e = Eigen::Vector3d::Unit(j % 3);
    const Eigen::Matrix3d L = j < 3 ? Eigen::Matrix3d(-Skew(e) * N) : Eigen::Matrix3d(-N * Skew(e));
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) D(El(r, c), j) = L(r, c);
  }
  return D;
}

RigCalibration SolveCpc(const CalibInput& in, const CpcStart& start, const CpcOptions& o) {
  const std::size_t K = in.cameras.size();
  int ref = -1;
  for (std::size_t k = 0; k < K; ++k)
    if (in.cameras[k].name == o.reference_camera) ref = static_cast<int>(k);
  if (ref < 0) throw UserError("paper: no camera named \"" + o.reference_camera + "\" (the reference camera of A10)");
  std::vector<std::vector<std::size_t>> tt(K);
  for (std::size_t v = 0; v < in.views.size(); ++v)
    if (in.views[v].kind == ImageKind::kTurntable) tt[static_cast<std::size_t>(in.views[v].camera)].push_back(v);
  const std::vector<std::size_t>& zv = tt[static_cast<std::size_t>(ref)];
  if (zv.size() < 3) throw UserError("paper: camera " + o.reference_camera + " has fewer than 3 turntable images");

  RigCalibration rig;
  rig.method = "paper";
  rig.C_p_b = in.C_p_b;
  rig.r_p_pb = in.r_p_pb;
  rig.cameras.resize(K);
  for (std::size_t k = 0; k < K; ++k) {
    rig.cameras[k].name = in.cameras[k].name;
    rig.cameras[k].intrinsics = start.intrinsics[k];
    rig.cameras[k].sigma_intrinsics = start.sigma_intrinsics[k];
  }

  // A.1: eq. A10 (generalised) for a = (alpha, beta, gamma) of C_w_t and c of C_b_z.
  std::vector<Eigen::RowVectorXd> rows;
  std::vector<double> rhs;
  int single_axis = 0;
  for (std::size_t v : zv) {
    const ViewObservation& view = in.views[v];
    const Eigen::Matrix3d N = PlatformRotation(view.main_cmd, view.aux_cmd) * in.C_p_b;
    const Eigen::Matrix3d M = start.C0_w_t.transpose() * start.view_T_w_k[v].C * start.B0_b_ref.transpose();
    const Eigen::Matrix<double, 9, 6> D = SmallAngleDesign(N);
    const Eigen::Matrix3d dM = M - N;
    const bool main_only = view.aux_cmd == 0.0, aux_only = view.main_cmd == 0.0 && !main_only;
    if (o.paper_rows_only && (main_only || aux_only)) {
      ++single_axis;
      for (int e : main_only ? kOmegaRows : kAuxRows) {
        rows.push_back(D.row(e));
        rhs.push_back(dM(e / 3, e % 3));
      }
    } else {
      for (int e = 0; e < 9; ++e) {
        rows.push_back(D.row(e));
        rhs.push_back(dM(e / 3, e % 3));
      }
    }
  }
  const Lsq rot = SolveLsq(rows, rhs, 6);
  const Eigen::Vector3d a = rot.x.head<3>(), c = rot.x.tail<3>();
  rig.C_w_t = start.C0_w_t * EulerToMatrix({a[0], a[1], a[2]});
  const Eigen::Matrix3d C_b_ref = EulerToMatrix({c[0], c[1], c[2]}) * start.B0_b_ref;
  rig.sigma_C_w_t = Sqrt3(rot.cov.topLeftCorner<3, 3>());
  {
    CameraResult& cr = rig.cameras[static_cast<std::size_t>(ref)];
    cr.C_k_b = C_b_ref.transpose();
    const Eigen::Matrix3d cc = rot.cov.bottomRightCorner<3, 3>();
    cr.sigma_rotation = Sqrt3(cc);
    cr.sigma_euler = EulerSigma(cr.C_k_b, cc);
  }
  // A11/A12: the other cameras.
  for (std::size_t k = 0; k < K; ++k) {
    if (static_cast<int>(k) == ref) continue;
    if (tt[k].empty()) {
      rig.notes.push_back("paper: camera " + in.cameras[k].name + " has no turntable image: C_k_b, r_b_bk not estimated");
      continue;
    }
    std::vector<Eigen::Matrix3d> Cs;
    for (std::size_t v : tt[k]) {
      const ViewObservation& view = in.views[v];
      const Eigen::Matrix3d C_w_b = rig.C_w_t * PlatformRotation(view.main_cmd, view.aux_cmd) * in.C_p_b;
      Cs.push_back(C_w_b.transpose() * start.view_T_w_k[v].C);  // C_b_k
    }
    Eigen::Matrix3d C_b_k, cov;
    MeanRotation(Cs, &C_b_k, &cov);
    CameraResult& cr = rig.cameras[k];
    cr.C_k_b = C_b_k.transpose();
    cr.sigma_rotation = Sqrt3(cov);
    cr.sigma_euler = EulerSigma(cr.C_k_b, cov);
  }

  // A.2: A13-A16 for the reference camera with the measured mount r_p_pb.
  TurntableMount m;
  m.C_w_t = rig.C_w_t;
  m.C_p_b = in.C_p_b;
  m.r_p_pb = in.r_p_pb;
  rows.clear();
  rhs.clear();
  for (std::size_t v : zv) {
    const ViewObservation& view = in.views[v];
    const Eigen::Matrix3d C_t_p = PlatformRotation(view.main_cmd, view.aux_cmd);
    const Eigen::Matrix3d C_w_b = rig.C_w_t * C_t_p * in.C_p_b;
    const Eigen::Vector3d b = start.view_T_w_k[v].r - rig.C_w_t * C_t_p * in.r_p_pb;
    for (int i = 0; i < 3; ++i) {
      Eigen::RowVectorXd row = Eigen::RowVectorXd::Zero(6);
      row[i] = 1.0;
      row.tail<3>() = C_w_b.row(i);
      rows.push_back(row);
      rhs.push_back(b[i]);
    }
  }
  const Lsq pos = SolveLsq(rows, rhs, 6);
  rig.r_w_wt = pos.x.head<3>();
  rig.sigma_r_w_wt = Sqrt3(pos.cov.topLeftCorner<3, 3>());
  m.r_w_wt = rig.r_w_wt;
  rig.cameras[static_cast<std::size_t>(ref)].r_b_bk = pos.x.tail<3>();
  rig.cameras[static_cast<std::size_t>(ref)].sigma_r_b_bk = Sqrt3(pos.cov.bottomRightCorner<3, 3>());
  // A17/A18.
  for (std::size_t k = 0; k < K; ++k) {
    if (static_cast<int>(k) == ref || tt[k].empty()) continue;
    std::vector<Eigen::Vector3d> rs;
    for (std::size_t v : tt[k]) {
      const Transform body = BodyInWorld(m, in.views[v].main_cmd, in.views[v].aux_cmd);
      rs.push_back(body.C.transpose() * (start.view_T_w_k[v].r - body.r));
    }
    MeanVector(rs, &rig.cameras[k].r_b_bk, &rig.cameras[k].sigma_r_b_bk);
  }

  rig.residuals = RigResiduals(in, rig, start.view_T_w_k);
  SetResidualRms(in, &rig);
  AppendCommandedAngles(in, &rig);
  std::ostringstream note;
  note << "paper: A10 from camera " << o.reference_camera << " (" << zv.size() << " images, " << single_axis
       << " single-axis with the paper's rows, the rest with all nine elements), residual RMS " << rot.rms
       << "; positions A13-A18 with the measured mount r_p_pb; turntable angles as commanded; sigma from each step's "
          "own scatter (not propagated)";
  rig.notes.push_back(note.str());
  return rig;
}

}  // namespace mfns::host
