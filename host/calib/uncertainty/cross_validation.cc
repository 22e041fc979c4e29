#include "host/calib/uncertainty/cross_validation.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <sstream>

#include "common/rotation/rotation.h"
#include "host/calib/uncertainty/chi_square.h"

namespace mfns::host {
namespace {

using StateVector = Eigen::Matrix<double, kCameraStateSize, 1>;

StateVector State(const CameraResult& c) {
  StateVector s = StateVector::Zero();
  s.head<kNumCameraParams>() = c.intrinsics.ToVector();
  s.segment<3>(kStatePosition) = c.r_b_bk;
  return s;  // the rotation entries are differences only (Difference)
}

StateVector Difference(const CameraResult& a, const CameraResult& b) {
  StateVector d = State(a) - State(b);
  d.segment<3>(kStateRotation) = LogSO3(a.C_k_b.transpose() * b.C_k_b);  // C_b_k,a = Exp(phi) C_b_k,b
  return d;
}

// chi2 = d^T S^-1 d over entries [first, first + n) whose variance is positive.
ChiSquareBlock ChiSquare(const StateVector& d, const CameraStateCovariance& S, int first, int n) {
  std::vector<int> used;
  for (int i = first; i < first + n; ++i)
    if (S(i, i) > 0.0) used.push_back(i);
  ChiSquareBlock out;
  const int m = static_cast<int>(used.size());
  if (m == 0) return out;
  Eigen::MatrixXd R(m, m);
  Eigen::VectorXd z(m);
  for (int a = 0; a < m; ++a) {
    const int ia = used[static_cast<std::size_t>(a)];
    z[a] = d[ia] / std::sqrt(S(ia, ia));
    for (int b = 0; b < m; ++b) {
      const int ib = used[static_cast<std::size_t>(b)];
      R(a, b) = S(ia, ib) / std::sqrt(S(ia, ia) * S(ib, ib));
    }
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(R);
  const double largest = eig.eigenvalues().maxCoeff();
  for (int i = 0; i < m; ++i) {
    const double lambda = eig.eigenvalues()[i];
    if (!(lambda > 1e-10 * largest)) continue;  // unobservable direction: no information either way
    const double projection = eig.eigenvectors().col(i).dot(z);
    out.chi2 += projection * projection / lambda;
    ++out.dof;
  }
  out.p_value = ChiSquareSurvival(out.chi2, out.dof);
  return out;
}

}  // namespace

std::vector<int> CrossValidationHalves(const CalibInput& in) {
  std::vector<int> next(2 * in.cameras.size(), 0);  // per camera and kind: the half of its next view
  std::vector<int> halves;
  for (const ViewObservation& v : in.views) {
    int& n = next[2 * static_cast<std::size_t>(v.camera) + (v.kind == ImageKind::kTurntable ? 0 : 1)];
    halves.push_back(n);
    n = 1 - n;
  }
  return halves;
}

CalibInput HalfInput(const CalibInput& in, const std::vector<int>& halves, int half) {
  CalibInput out = in;
  out.views.clear();
  out.skipped.clear();
  for (std::size_t v = 0; v < in.views.size(); ++v)
    if (halves[v] == half) out.views.push_back(in.views[v]);
  return out;
}

CrossValidation CompareHalves(const RigCalibration& half0, const RigCalibration& half1) {
  CrossValidation cv;
  cv.pass = true;
  for (std::size_t k = 0; k < half0.cameras.size() && k < half1.cameras.size(); ++k) {
    const CameraResult &a = half0.cameras[k], &b = half1.cameras[k];
    const StateVector d = Difference(a, b);
    const CameraStateCovariance S = a.covariance + b.covariance;
    CameraCrossValidation c;
    c.name = a.name;
    c.rotation_deg = RadToDeg(d.segment<3>(kStateRotation).norm());
    c.rotation_sigma_deg = RadToDeg(std::sqrt(S.block<3, 3>(kStateRotation, kStateRotation).trace()));
    c.position_mm = d.segment<3>(kStatePosition).norm() * 1e3;
    c.position_sigma_mm = std::sqrt(S.block<3, 3>(kStatePosition, kStatePosition).trace()) * 1e3;
    c.intrinsics = ChiSquare(d, S, 0, kNumCameraParams);
    c.rotation = ChiSquare(d, S, kStateRotation, 3);
    c.position = ChiSquare(d, S, kStatePosition, 3);
    c.all = ChiSquare(d, S, 0, kCameraStateSize);
    c.pass = c.all.dof > 0 && c.all.p_value >= kCrossValidationMinPValue;
    cv.pass = cv.pass && c.pass;
    cv.cameras.push_back(c);
  }
  cv.pass = cv.pass && !cv.cameras.empty();
  return cv;
}

std::string FormatCrossValidation(const CrossValidation& cv) {
  std::ostringstream o;
  o.precision(4);
  for (const CameraCrossValidation& c : cv.cameras)
    o << "cross-validation: camera " << c.name << ": C_k_b differs by " << c.rotation_deg << " deg (expected "
      << c.rotation_sigma_deg << "), r_b_bk by " << c.position_mm << " mm (expected " << c.position_sigma_mm
      << "); chi2 " << c.all.chi2 << " for " << c.all.dof << " dof, p " << c.all.p_value << ": "
      << (c.pass ? "pass" : "FAIL") << "\n";
  o << "cross-validation: " << (cv.pass ? "PASS" : "FAIL") << " (halves of " << cv.views[0] << " and " << cv.views[1]
    << " images; a camera fails below p = " << kCrossValidationMinPValue << ")\n";
  return o.str();
}

std::string FailedCameras(const CrossValidation& cv) {
  std::ostringstream o;
  o.precision(3);
  for (const CameraCrossValidation& c : cv.cameras)
    if (!c.pass)
      o << (o.tellp() > 0 ? "; " : "") << "camera " << c.name << ": chi2 " << c.all.chi2 << " for " << c.all.dof
        << " dof, p " << c.all.p_value;
  return o.str();
}

std::string FormatCrossValidationCsv(const CrossValidation& cv) {
  std::ostringstream o;
  o.precision(8);
  o << "camera,images_0,images_1,rotation_deg,rotation_sigma_deg,position_mm,position_sigma_mm,chi2_intrinsics,"
       "dof_intrinsics,chi2_rotation,dof_rotation,chi2_position,dof_position,chi2,dof,p_value,pass\n";
  for (const CameraCrossValidation& c : cv.cameras)
    o << c.name << "," << c.images[0] << "," << c.images[1] << "," << c.rotation_deg << "," << c.rotation_sigma_deg
      << "," << c.position_mm << "," << c.position_sigma_mm << "," << c.intrinsics.chi2 << "," << c.intrinsics.dof
      << "," << c.rotation.chi2 << "," << c.rotation.dof << "," << c.position.chi2 << "," << c.position.dof << ","
      << c.all.chi2 << "," << c.all.dof << "," << c.all.p_value << "," << (c.pass ? "yes" : "no") << "\n";
  return o.str();
}

}  // namespace mfns::host
