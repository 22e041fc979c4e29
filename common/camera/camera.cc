#include "common/camera/camera.h"

#include <cmath>

#include "common/limits.h"

namespace mfns {
namespace {

// Points closer to the image plane than this (in units of the depth) have no image.
constexpr double kMinDepth = 1e-9;

struct DistortionTerms {
  double r2, radial, dradial_dr2;
};

DistortionTerms Terms(const CameraIntrinsics& cam, const Eigen::Vector2d& x) {
  const double r2 = x.squaredNorm();
  const double k1 = cam.kc[0], k2 = cam.kc[1], k3 = cam.kc[4];
  return {r2, 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3)), k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)};
}

// Pixel from distorted normalised coordinates.
Eigen::Vector2d ToPixel(const CameraIntrinsics& cam, const Eigen::Vector2d& xd) {
  return {cam.alpha_x * xd.x() + cam.skew * xd.y() + cam.u0, cam.alpha_y * xd.y() + cam.v0};
}

}  // namespace

CameraParamVector CameraIntrinsics::ToVector() const {
  CameraParamVector p;
  p << alpha_x, alpha_y, skew, u0, v0, kc[0], kc[1], kc[2], kc[3], kc[4];
  return p;
}

void CameraIntrinsics::SetFromVector(const CameraParamVector& p) {
  alpha_x = p[kAlphaX];
  alpha_y = p[kAlphaY];
  skew = p[kSkew];
  u0 = p[kU0];
  v0 = p[kV0];
  for (int i = 0; i < 5; ++i) kc[static_cast<std::size_t>(i)] = p[kKc1 + i];
}

Eigen::Vector2d Distort(const CameraIntrinsics& cam, const Eigen::Vector2d& x_n,
                        Eigen::Matrix2d* J_xd_x) {
  const double x = x_n.x(), y = x_n.y(), p1 = cam.kc[2], p2 = cam.kc[3];
  const DistortionTerms t = Terms(cam, x_n);
  const Eigen::Vector2d xd(x * t.radial + 2.0 * p1 * x * y + p2 * (t.r2 + 2.0 * x * x),
                           y * t.radial + p1 * (t.r2 + 2.0 * y * y) + 2.0 * p2 * x * y);
  if (J_xd_x != nullptr) {
    // d(radial)/dx = dradial_dr2 * 2x, likewise for y.
    const double drx = 2.0 * x * t.dradial_dr2, dry = 2.0 * y * t.dradial_dr2;
    (*J_xd_x) << t.radial + x * drx + 2.0 * p1 * y + 6.0 * p2 * x,
        x * dry + 2.0 * p1 * x + 2.0 * p2 * y,
        y * drx + 2.0 * p1 * x + 2.0 * p2 * y,
        t.radial + y * dry + 6.0 * p1 * y + 2.0 * p2 * x;
  }
  return xd;
}

ProjectStatus Project(const CameraIntrinsics& cam, const Eigen::Vector3d& p_k,
                      Eigen::Vector2d* uv_px, Eigen::Matrix<double, 2, 3>* J_uv_p,
                      Eigen::Matrix<double, 2, kNumCameraParams>* J_uv_params) {
  if (!p_k.allFinite()) return ProjectStatus::kNonFinite;
  const double z = p_k.z();
  if (z <= kMinDepth * p_k.norm()) return ProjectStatus::kBehindCamera;
  const Eigen::Vector2d x_n(p_k.x() / z, p_k.y() / z);
  Eigen::Matrix2d J_xd_x;
  const Eigen::Vector2d xd = Distort(cam, x_n, &J_xd_x);
  const Eigen::Vector2d uv = ToPixel(cam, xd);
  if (!uv.allFinite()) return ProjectStatus::kNonFinite;
  *uv_px = uv;

  Eigen::Matrix2d J_uv_xd;
  J_uv_xd << cam.alpha_x, cam.skew, 0.0, cam.alpha_y;
  if (J_uv_p != nullptr) {
    Eigen::Matrix<double, 2, 3> J_x_p;
    J_x_p << 1.0 / z, 0.0, -x_n.x() / z, 0.0, 1.0 / z, -x_n.y() / z;
    *J_uv_p = J_uv_xd * J_xd_x * J_x_p;
  }
  if (J_uv_params != nullptr) {
    const double x = x_n.x(), y = x_n.y();
    const double r2 = x_n.squaredNorm();
    Eigen::Matrix<double, 2, 5> J_xd_kc;
    J_xd_kc << x * r2, x * r2 * r2, 2.0 * x * y, r2 + 2.0 * x * x, x * r2 * r2 * r2,
        y * r2, y * r2 * r2, r2 + 2.0 * y * y, 2.0 * x * y, y * r2 * r2 * r2;
    J_uv_params->setZero();
    (*J_uv_params)(0, kAlphaX) = xd.x();
    (*J_uv_params)(0, kSkew) = xd.y();
    (*J_uv_params)(0, kU0) = 1.0;
    (*J_uv_params)(1, kAlphaY) = xd.y();
    (*J_uv_params)(1, kV0) = 1.0;
    J_uv_params->block<2, 5>(0, kKc1) = J_uv_xd * J_xd_kc;
  }
  return ProjectStatus::kOk;
}

UnprojectStatus Unproject(const CameraIntrinsics& cam, const Eigen::Vector2d& uv_px,
                          Eigen::Vector2d* x_n, double tol_px) {
  if (!uv_px.allFinite()) return UnprojectStatus::kNonFinite;
  // Invert the (linear) pixel mapping exactly, then the distortion by Newton's method.
  const double yd = (uv_px.y() - cam.v0) / cam.alpha_y;
  const Eigen::Vector2d xd_target((uv_px.x() - cam.u0 - cam.skew * yd) / cam.alpha_x, yd);
  Eigen::Vector2d x = xd_target;
  for (int i = 0; i < limits::kMaxUnprojectIterations; ++i) {
    Eigen::Matrix2d J;
    const Eigen::Vector2d residual = Distort(cam, x, &J) - xd_target;
    if (!residual.allFinite()) return UnprojectStatus::kNonFinite;
    if ((ToPixel(cam, residual + xd_target) - uv_px).norm() <= tol_px) {
      *x_n = x;
      return UnprojectStatus::kOk;
    }
    // Newton step through the 2x2 inverse; a vanishing determinant is a fold of the model.
    const double det = J(0, 0) * J(1, 1) - J(0, 1) * J(1, 0);
    if (!(std::abs(det) > 1e-12)) return UnprojectStatus::kNotConverged;
    x.x() -= (J(1, 1) * residual.x() - J(0, 1) * residual.y()) / det;
    x.y() -= (J(0, 0) * residual.y() - J(1, 0) * residual.x()) / det;
  }
  return UnprojectStatus::kNotConverged;
}

bool InImage(const CameraIntrinsics& cam, const Eigen::Vector2d& uv_px, double margin_px) {
  return uv_px.x() >= -0.5 + margin_px && uv_px.x() <= cam.width - 0.5 - margin_px &&
         uv_px.y() >= -0.5 + margin_px && uv_px.y() <= cam.height - 0.5 - margin_px;
}

}  // namespace mfns
