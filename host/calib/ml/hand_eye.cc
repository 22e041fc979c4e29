#include "host/calib/ml/hand_eye.h"

#include <Eigen/Dense>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "common/rotation/rotation.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

// Column-major vec index of element (r, c) of a 3x3 matrix.
constexpr int Vec(int r, int c) { return 3 * c + r; }

// (I3 (x) A) and (B^T (x) I3) as 9x9 matrices acting on column-major vec().
Eigen::Matrix<double, 9, 9> LeftProduct(const Eigen::Matrix3d& A) {  // vec(A X)
  Eigen::Matrix<double, 9, 9> M = Eigen::Matrix<double, 9, 9>::Zero();
  for (int c = 0; c < 3; ++c) M.block<3, 3>(3 * c, 3 * c) = A;
  return M;
}
Eigen::Matrix<double, 9, 9> RightProduct(const Eigen::Matrix3d& B) {  // vec(X B)
  Eigen::Matrix<double, 9, 9> M = Eigen::Matrix<double, 9, 9>::Zero();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      for (int l = 0; l < 3; ++l) M(Vec(r, c), Vec(r, l)) = B(l, c);  // (X B)(r,c) = sum_l X(r,l) B(l,c)
  return M;
}

Eigen::Matrix3d Unvec(const Eigen::VectorXd& x, int offset) {
  Eigen::Matrix3d X;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) X(r, c) = x[offset + Vec(r, c)];
  return X;
}

void SolveTranslations(const std::vector<HandEyeView>& views, const std::vector<int>& col, int num_solved,
                       const Eigen::Matrix3d& C_p_b, const Eigen::Vector3d& r_p_pb, HandEyeResult* res) {
  const int n = 3 + 3 * num_solved;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(3 * static_cast<int>(views.size()), n);
  Eigen::VectorXd b(3 * static_cast<int>(views.size()));
  for (std::size_t v = 0; v < views.size(); ++v) {
    const HandEyeView& hv = views[v];
    const Eigen::Matrix3d C_t_p = PlatformRotation(hv.main, hv.aux);
    const Eigen::Matrix3d C_w_b = res->C_w_t * C_t_p * C_p_b;
    const int row = 3 * static_cast<int>(v);
    A.block<3, 3>(row, 0).setIdentity();
    A.block<3, 3>(row, 3 + 3 * col[static_cast<std::size_t>(hv.camera)]) = C_w_b;
    b.segment<3>(row) = hv.T_w_k.r - res->C_w_t * C_t_p * r_p_pb;
  }
  const Eigen::VectorXd y = A.colPivHouseholderQr().solve(b);
  res->r_w_wt = y.head<3>();
  for (std::size_t k = 0; k < col.size(); ++k)
    if (col[k] >= 0) res->r_b_bk[k] = y.segment<3>(3 + 3 * col[k]);
  res->position_rms = std::sqrt((A * y - b).squaredNorm() / static_cast<double>(views.size()));
}

void RotationRms(const std::vector<HandEyeView>& views, const Eigen::Matrix3d& C_p_b, HandEyeResult* res) {
  double sum2 = 0;
  for (const HandEyeView& hv : views) {
    const Eigen::Matrix3d lhs = hv.T_w_k.C * res->C_k_b[static_cast<std::size_t>(hv.camera)];
    const Eigen::Matrix3d rhs = res->C_w_t * PlatformRotation(hv.main, hv.aux) * C_p_b;
    sum2 += LogSO3(lhs * rhs.transpose()).squaredNorm();
  }
  res->rotation_rms = std::sqrt(sum2 / static_cast<double>(views.size()));
}

}  // namespace

HandEyeResult SolveHandEyeLinear(const std::vector<HandEyeView>& views, int num_cameras, const Eigen::Matrix3d& C_p_b,
                                 const Eigen::Vector3d& r_p_pb) {
  if (views.size() < 2) throw UserError("hand-eye: at least 2 turntable images are needed");
  HandEyeResult res;
  res.C_k_b.assign(static_cast<std::size_t>(num_cameras), Eigen::Matrix3d::Identity());
  res.r_b_bk.assign(static_cast<std::size_t>(num_cameras), Eigen::Vector3d::Zero());
  res.solved.assign(static_cast<std::size_t>(num_cameras), false);
  std::vector<int> col(static_cast<std::size_t>(num_cameras), -1);
  int num_solved = 0;
  for (const HandEyeView& v : views)
    if (col[static_cast<std::size_t>(v.camera)] < 0) col[static_cast<std::size_t>(v.camera)] = num_solved++;
  const int n = 9 + 9 * num_solved;
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(9 * static_cast<int>(views.size()), n);
  for (std::size_t v = 0; v < views.size(); ++v) {
    const HandEyeView& hv = views[v];
    const Eigen::Matrix3d C_t_b = PlatformRotation(hv.main, hv.aux) * C_p_b;
    const int row = 9 * static_cast<int>(v);
    M.block<9, 9>(row, 9 + 9 * col[static_cast<std::size_t>(hv.camera)]) = LeftProduct(hv.T_w_k.C);
    M.block<9, 9>(row, 0) = -RightProduct(C_t_b);
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(M, Eigen::ComputeThinV);
  const Eigen::VectorXd s = svd.singularValues();
  // One-dimensional null space expected: the smallest singular value well below the next.
  if (!(s[n - 1] < 0.5 * s[n - 2]))
    throw UserError("hand-eye: turntable rotations do not determine the rig (rotate about both axes)");
  Eigen::VectorXd x = svd.matrixV().col(n - 1);
  const double det = Unvec(x, 0).determinant();
  if (!(std::abs(det) > 1e-12)) throw UserError("hand-eye: degenerate rotation solution");
  x /= std::cbrt(det);
  res.C_w_t = NearestRotation(Unvec(x, 0));
  for (int k = 0; k < num_cameras; ++k) {
    if (col[static_cast<std::size_t>(k)] < 0) continue;
    res.C_k_b[static_cast<std::size_t>(k)] = NearestRotation(Unvec(x, 9 + 9 * col[static_cast<std::size_t>(k)]));
    res.solved[static_cast<std::size_t>(k)] = true;
  }
  RotationRms(views, C_p_b, &res);
  SolveTranslations(views, col, num_solved, C_p_b, r_p_pb, &res);
  return res;
}

HandEyeResult SolveHandEyeOpenCv(const std::vector<HandEyeView>& views, int num_cameras, const Eigen::Matrix3d& C_p_b,
                                 const Eigen::Vector3d& r_p_pb) {
  if (views.size() < 3) throw UserError("calibrateRobotWorldHandEye needs at least 3 images of one camera");
  // OpenCV's frames: world = w (target), cam = k, base = t (turntable), gripper = b (body):
  //   T_k_w T_w_t = T_k_b T_b_t.
  std::vector<cv::Mat> R_w2c, t_w2c, R_b2g, t_b2g;
  for (const HandEyeView& hv : views) {
    const Eigen::Matrix3d C_k_w = hv.T_w_k.C.transpose();
    const Eigen::Vector3d t_k = -C_k_w * hv.T_w_k.r;  // r_k_kw
    const Eigen::Matrix3d C_t_b = PlatformRotation(hv.main, hv.aux) * C_p_b;
    const Eigen::Vector3d r_t_tb = PlatformRotation(hv.main, hv.aux) * r_p_pb;
    const Eigen::Matrix3d C_b_t = C_t_b.transpose();
    const Eigen::Vector3d t_b = -C_b_t * r_t_tb;
    cv::Mat a, b, c, d;
    cv::eigen2cv(C_k_w, a);
    cv::eigen2cv(t_k, b);
    cv::eigen2cv(C_b_t, c);
    cv::eigen2cv(t_b, d);
    R_w2c.push_back(a);
    t_w2c.push_back(b);
    R_b2g.push_back(c);
    t_b2g.push_back(d);
  }
  cv::Mat R_base2world, t_base2world, R_g2c, t_g2c;
  cv::calibrateRobotWorldHandEye(R_w2c, t_w2c, R_b2g, t_b2g, R_base2world, t_base2world, R_g2c, t_g2c,
                                 cv::CALIB_ROBOT_WORLD_HAND_EYE_SHAH);
  HandEyeResult res;
  res.C_k_b.assign(static_cast<std::size_t>(num_cameras), Eigen::Matrix3d::Identity());
  res.r_b_bk.assign(static_cast<std::size_t>(num_cameras), Eigen::Vector3d::Zero());
  res.solved.assign(static_cast<std::size_t>(num_cameras), false);
  const std::size_t k = static_cast<std::size_t>(views.front().camera);
  Eigen::Matrix3d C_w_t, C_k_b;
  Eigen::Vector3d r_w_wt, t_kb;
  cv::cv2eigen(R_base2world, C_w_t);
  cv::cv2eigen(t_base2world, r_w_wt);
  cv::cv2eigen(R_g2c, C_k_b);
  cv::cv2eigen(t_g2c, t_kb);  // r_k_kb: body origin in camera k
  res.C_w_t = NearestRotation(C_w_t);
  res.r_w_wt = r_w_wt;
  res.C_k_b[k] = NearestRotation(C_k_b);
  res.r_b_bk[k] = -res.C_k_b[k].transpose() * t_kb;
  res.solved[k] = true;
  RotationRms(views, C_p_b, &res);
  return res;
}

}  // namespace mfns::host
