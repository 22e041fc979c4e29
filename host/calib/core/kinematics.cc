#include "host/calib/core/kinematics.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>

#include "common/rotation/rotation.h"

namespace mfns::host {

Eigen::Matrix3d PlatformRotation(double main_rad, double aux_rad) {
  return R1(aux_rad).transpose() * R3(main_rad).transpose();
}

Transform BodyInWorld(const TurntableMount& m, double main_rad, double aux_rad) {
  const Eigen::Matrix3d C_t_p = PlatformRotation(main_rad, aux_rad);
  Transform b;
  b.C = m.C_w_t * C_t_p * m.C_p_b;
  b.r = m.r_w_wt + m.C_w_t * (C_t_p * m.r_p_pb);
  return b;
}

Transform CameraInWorld(const Transform& body_in_world, const Eigen::Matrix3d& C_k_b, const Eigen::Vector3d& r_b_bk) {
  Transform k;
  k.C = body_in_world.C * C_k_b.transpose();
  k.r = body_in_world.r + body_in_world.C * r_b_bk;
  return k;
}

double RotationAngle(const Eigen::Matrix3d& C) { return LogSO3(C).norm(); }

Eigen::Matrix3d NearestAxisAligned(const Eigen::Matrix3d& C) {
  // Try the 24 rotations among the 48 signed permutations; keep the one with the largest
  // trace(P^T C) (the smallest rotation angle between them).
  std::array<int, 3> perm{0, 1, 2};
  Eigen::Matrix3d best = Eigen::Matrix3d::Identity();
  double best_score = -1e300;
  do {
    for (int signs = 0; signs < 8; ++signs) {
      Eigen::Matrix3d P = Eigen::Matrix3d::Zero();
      for (int r = 0; r < 3; ++r) P(r, perm[static_cast<std::size_t>(r)]) = (signs >> r) & 1 ? -1.0 : 1.0;
      if (P.determinant() < 0.0) continue;
      const double score = (P.transpose() * C).trace();
      if (score > best_score) {
        best_score = score;
        best = P;
      }
    }
  } while (std::next_permutation(perm.begin(), perm.end()));
  return best;
}

}  // namespace mfns::host
