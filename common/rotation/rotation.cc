#include "common/rotation/rotation.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

namespace mfns {

namespace {
// x to (-half, half] (half > 0): std::remainder gives [-half, half], -half mapped to +half.
double WrapTo(double x, double half) {
  if (!std::isfinite(x)) return x;
  const double w = std::remainder(x, 2.0 * half);
  return w <= -half ? w + 2.0 * half : w;
}
}  // namespace

double WrapPi(double a) { return WrapTo(a, kPi); }
double Wrap180Deg(double a_deg) { return WrapTo(a_deg, 180.0); }

Eigen::Matrix3d R1(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Eigen::Matrix3d R;
  R << 1, 0, 0, 0, c, s, 0, -s, c;
  return R;
}

Eigen::Matrix3d R2(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Eigen::Matrix3d R;
  R << c, 0, -s, 0, 1, 0, s, 0, c;
  return R;
}

Eigen::Matrix3d R3(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Eigen::Matrix3d R;
  R << c, s, 0, -s, c, 0, 0, 0, 1;
  return R;
}

Eigen::Matrix3d EulerToMatrix(const EulerAngles& e) { return R3(e.psi) * R1(e.phi) * R2(e.theta); }

EulerAngles MatrixToEuler(const Eigen::Matrix3d& C) {
  EulerAngles e;
  const double s_phi = std::clamp(-C(2, 1), -1.0, 1.0);
  e.phi = std::asin(s_phi);
  // cos(phi) from the other elements of row 2 keeps precision near gimbal lock.
  const double c_phi = std::hypot(C(2, 0), C(2, 2));
  if (c_phi > 1e-12) {
    e.theta = std::atan2(C(2, 0), C(2, 2));
    e.psi = std::atan2(C(0, 1), C(1, 1));
  } else {
    // Gimbal lock: R1(+-pi/2) couples theta and psi; with psi = 0 row 0 is
    // [cos(theta), 0, -sin(theta)] for either sign of phi.
    e.psi = 0.0;
    e.theta = std::atan2(-C(0, 2), C(0, 0));
  }
  return e;
}

Eigen::Quaterniond EulerToQuaternion(const EulerAngles& e) {
  return Eigen::Quaterniond(EulerToMatrix(e)).normalized();
}

EulerAngles QuaternionToEuler(const Eigen::Quaterniond& q) {
  return MatrixToEuler(q.normalized().toRotationMatrix());
}

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}

Eigen::Matrix3d SmallAngleMatrix(const Eigen::Vector3d& angles) {
  return Eigen::Matrix3d::Identity() - Skew(angles);
}

Eigen::Matrix3d ExpSO3(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  if (angle < 1e-12) return Eigen::Matrix3d::Identity() + Skew(w);
  return Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
}

Eigen::Matrix3d RightJacobianSO3(const Eigen::Vector3d& w) {
  const double t2 = w.squaredNorm();
  const Eigen::Matrix3d W = Skew(w);
  // I - (1 - cos t)/t^2 W + (t - sin t)/t^3 W^2; series below 1e-4 rad (terms to t^4 exact to
  // ~1e-17).
  double a = 0.5 - t2 / 24.0, b = 1.0 / 6.0 - t2 / 120.0;
  if (t2 > 1e-8) {
    const double t = std::sqrt(t2);
    a = (1.0 - std::cos(t)) / t2;
    b = (t - std::sin(t)) / (t2 * t);
  }
  return Eigen::Matrix3d::Identity() - a * W + b * W * W;
}

Eigen::Vector3d LogSO3(const Eigen::Matrix3d& C) {
  const Eigen::AngleAxisd aa(C);
  return aa.angle() * aa.axis();
}

bool IsRotation(const Eigen::Matrix3d& C, double tol) {
  if (!C.allFinite()) return false;
  const double ortho = (C.transpose() * C - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  return ortho <= tol && std::abs(C.determinant() - 1.0) <= tol;
}

Eigen::Matrix3d NearestRotation(const Eigen::Matrix3d& M) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

}  // namespace mfns
