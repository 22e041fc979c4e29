#include "firmware/modules/identify/pose_filter.h"

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>

#include "common/rotation/rotation.h"
#include "firmware/modules/identify/motion_model.h"

namespace mfns::fw {
namespace {

// SO(3)'s right Jacobian: Exp(phi + d) ~= Exp(phi) Exp(Jr(phi) d).
Eigen::Matrix3d RightJacobian(const Eigen::Vector3d& phi) {
  const double th = phi.norm();
  const Eigen::Matrix3d K = Skew(phi);
  if (th < 1e-6) return Eigen::Matrix3d::Identity() - 0.5 * K;
  return Eigen::Matrix3d::Identity() - (1.0 - std::cos(th)) / (th * th) * K +
         (th - std::sin(th)) / (th * th * th) * K * K;
}

bool Finite(const BodyPose& p) { return p.r_w_wb.allFinite() && p.C_w_b.allFinite(); }

}  // namespace

bool PoseFilterNoise::IsValid() const {
  return accel_psd > 0.0 && angular_accel_psd > 0.0 && initial_speed_sigma > 0.0 && initial_rate_sigma > 0.0 &&
         std::isfinite(accel_psd + angular_accel_psd + initial_speed_sigma + initial_rate_sigma);
}

bool PoseFilter::Start(const BodyPose& pose, std::uint64_t t_ns, const Matrix6d& pose_cov,
                       const PoseFilterNoise& noise) {
  started_ = false;
  if (!noise.IsValid() || !Finite(pose) || !pose_cov.allFinite()) return false;
  noise_ = noise;
  t_ns_ = t_ns;
  pose_ = pose;
  v_w_.setZero();
  omega_b_.setZero();
  P_.setZero();
  P_.topLeftCorner<6, 6>() = 0.5 * (pose_cov + pose_cov.transpose());
  P_.block<3, 3>(6, 6).diagonal().setConstant(noise.initial_speed_sigma * noise.initial_speed_sigma);
  P_.block<3, 3>(9, 9).diagonal().setConstant(noise.initial_rate_sigma * noise.initial_rate_sigma);
  started_ = true;
  return true;
}

PoseFilter::Matrix12d PoseFilter::Transition(const Eigen::Vector3d& omega_b, double dt) {
  Matrix12d F = Matrix12d::Identity();
  F.block<3, 3>(0, 6) = dt * Eigen::Matrix3d::Identity();
  // C Exp(dth) Exp((w + dw) dt) = C Exp(w dt) Exp(dth'): dth' = Exp(-w dt) dth + Jr(w dt) dt dw.
  F.block<3, 3>(3, 3) = ExpSO3(-omega_b * dt);
  F.block<3, 3>(3, 9) = dt * RightJacobian(omega_b * dt);
  return F;
}

PoseFilter::Matrix12d PoseFilter::ProcessNoise(const PoseFilterNoise& noise, double dt) {
  Matrix12d Q = Matrix12d::Zero();
  const double psd[2] = {noise.accel_psd, noise.angular_accel_psd};
  for (int k = 0; k < 2; ++k) {
    const int pos = 3 * k, vel = 6 + 3 * k;  // (dr, dv), then (dtheta, domega)
    for (int i = 0; i < 3; ++i) {
      Q(pos + i, pos + i) = psd[k] * dt * dt * dt / 3.0;
      Q(pos + i, vel + i) = Q(vel + i, pos + i) = psd[k] * dt * dt / 2.0;
      Q(vel + i, vel + i) = psd[k] * dt;
    }
  }
  return Q;
}

void PoseFilter::Propagate(std::uint64_t t_ns, BodyPose* pose, Matrix12d* P) const {
  const double dt = std::max(0.0, Seconds(t_ns, t_ns_));
  pose->r_w_wb = pose_.r_w_wb + v_w_ * dt;
  pose->C_w_b = pose_.C_w_b * ExpSO3(omega_b_ * dt);
  const Matrix12d F = Transition(omega_b_, dt);
  *P = F * P_ * F.transpose() + ProcessNoise(noise_, dt);
}

bool PoseFilter::Predict(std::uint64_t t_ns, BodyPose* pose, Matrix6d* P_pose) const {
  if (!started_) return false;
  Matrix12d P;
  Propagate(t_ns, pose, &P);
  *P_pose = P.topLeftCorner<6, 6>();
  return true;
}

double PoseFilter::Distance2(const BodyPose& z, const Matrix6d& R, std::uint64_t t_ns) const {
  BodyPose pred;
  Matrix6d P;
  if (!Predict(t_ns, &pred, &P) || !Finite(z) || !R.allFinite()) return std::numeric_limits<double>::infinity();
  PoseDelta d;
  d << z.r_w_wb - pred.r_w_wb, LogSO3(pred.C_w_b.transpose() * z.C_w_b);
  const Eigen::LLT<Matrix6d> llt(P + R);
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
  return d.dot(llt.solve(d));
}

bool PoseFilter::Update(const BodyPose& z, std::uint64_t t_ns, const Matrix6d& R) {
  if (!started_ || t_ns < t_ns_ || !Finite(z) || !R.allFinite()) return false;
  BodyPose pred;
  Matrix12d P;
  Propagate(t_ns, &pred, &P);
  PoseDelta y;
  y << z.r_w_wb - pred.r_w_wb, LogSO3(pred.C_w_b.transpose() * z.C_w_b);
  const Matrix6d S = P.topLeftCorner<6, 6>() + R;
  const Eigen::LLT<Matrix6d> llt(S);
  if (llt.info() != Eigen::Success) return false;
  // K = P H^T S^-1 with H = [I6 0].
  const Eigen::Matrix<double, 12, 6> K = llt.solve(P.leftCols<6>().transpose()).transpose();
  const Vector12d dx = K * y;
  pose_.r_w_wb = pred.r_w_wb + dx.segment<3>(0);
  pose_.C_w_b = pred.C_w_b * ExpSO3(dx.segment<3>(3));
  v_w_ += dx.segment<3>(6);
  omega_b_ += dx.segment<3>(9);
  // Joseph form: stays symmetric positive semi-definite whatever the gain's rounding.
  Matrix12d IKH = Matrix12d::Identity();
  IKH.leftCols<6>() -= K;
  P_ = IKH * P * IKH.transpose() + K * R * K.transpose();
  P_ = 0.5 * (P_ + P_.transpose());
  t_ns_ = t_ns;
  return true;
}

}  // namespace mfns::fw
