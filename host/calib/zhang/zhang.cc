#include "host/calib/zhang/zhang.h"

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <string>

#include "host/util/user_error.h"

namespace mfns::host {

ZhangResult CalibrateZhang(const std::vector<std::vector<CornerObs>>& views,
                           const std::vector<Eigen::Vector3d>& target_points, int width, int height,
                           const ZhangOptions& options) {
  if (views.size() < 3)
    throw UserError("Zhang's method needs at least 3 usable views, got " + std::to_string(views.size()));
  std::vector<std::vector<cv::Point3f>> obj(views.size());
  std::vector<std::vector<cv::Point2f>> img(views.size());
  ZhangResult res;
  for (std::size_t v = 0; v < views.size(); ++v) {
    for (const CornerObs& c : views[v]) {
      const Eigen::Vector3d& P = target_points.at(static_cast<std::size_t>(c.id));
      obj[v].emplace_back(static_cast<float>(P.x()), static_cast<float>(P.y()), static_cast<float>(P.z()));
      img[v].emplace_back(static_cast<float>(c.uv.x()), static_cast<float>(c.uv.y()));
    }
    res.num_corners += static_cast<int>(views[v].size());
  }
  cv::Mat K, dist, std_intr, std_extr, per_view;
  std::vector<cv::Mat> rvecs, tvecs;
  int flags = 0;
  if (options.fix_k3) flags |= cv::CALIB_FIX_K3;
  res.rms_px = cv::calibrateCamera(obj, img, cv::Size(width, height), K, dist, rvecs, tvecs, std_intr, std_extr, per_view,
                                   flags, cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 60, 1e-10));
  CameraIntrinsics& cam = res.camera;
  cam.width = width;
  cam.height = height;
  cam.alpha_x = K.at<double>(0, 0);
  cam.alpha_y = K.at<double>(1, 1);
  cam.skew = 0.0;
  cam.u0 = K.at<double>(0, 2);
  cam.v0 = K.at<double>(1, 2);
  for (int i = 0; i < 5; ++i) cam.kc[static_cast<std::size_t>(i)] = dist.at<double>(i);
  double scale = 1.0;
#if CV_VERSION_MAJOR < 4 || (CV_VERSION_MAJOR == 4 && CV_VERSION_MINOR < 8)
  // OpenCV before 4.8 divides the sum of squared residual norms by (points - parameters)
  // instead of (2 points - parameters) (opencv#19803, fixed by opencv#22992): its sigma is
  // about sqrt(2) too large. Rescale to the unbiased residual variance.
  {
    const double n = res.num_corners, p = (options.fix_k3 ? 8.0 : 9.0) + 6.0 * static_cast<double>(views.size());
    if (2 * n > p && n > p) scale = std::sqrt((n - p) / (2 * n - p));
  }
#endif
  const auto sd = [&](int i) { return scale * std_intr.at<double>(i); };
  res.sigma << sd(0), sd(1), 0.0, sd(2), sd(3), sd(4), sd(5), sd(6), sd(7), options.fix_k3 ? 0.0 : sd(8);
  for (std::size_t v = 0; v < views.size(); ++v) {
    cv::Mat R;
    cv::Rodrigues(rvecs[v], R);
    ZhangView zv;
    Eigen::Vector3d t;
    cv::cv2eigen(R, zv.C_k_w);
    cv::cv2eigen(tvecs[v], t);
    zv.r_w_wk = -zv.C_k_w.transpose() * t;
    double sum2 = 0;
    for (const CornerObs& c : views[v]) {
      const Eigen::Vector3d p_k = zv.C_k_w * (target_points[static_cast<std::size_t>(c.id)] - zv.r_w_wk);
      Eigen::Vector2d uv;
      if (Project(cam, p_k, &uv) != ProjectStatus::kOk) uv = Eigen::Vector2d::Constant(std::nan(""));
      zv.residuals.push_back(uv - c.uv);
      sum2 += zv.residuals.back().squaredNorm();
    }
    zv.rms_px = std::sqrt(sum2 / static_cast<double>(std::max<std::size_t>(1, views[v].size())));
    res.views.push_back(std::move(zv));
  }
  return res;
}

}  // namespace mfns::host
