#include "host/sim/render/target_renderer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "common/rotation/rotation.h"

namespace mfns::host {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kMaxClipCells = 64;
constexpr int kFallbackSamples = 4;

// A convex polygon with room for a quadrilateral clipped by 4 half-planes (one vertex more
// per clip).
struct Polygon {
  std::array<Eigen::Vector2d, 10> v;
  int n = 0;
};

// Keeps the part of `in` with coordinate `axis` on the kept side of `bound`
// (>= bound when keep_above, <= bound otherwise).
Polygon Clip(const Polygon& in, int axis, double bound, bool keep_above) {
  Polygon out;
  if (in.n == 0) return out;
  auto inside = [&](const Eigen::Vector2d& p) { return keep_above ? p[axis] >= bound : p[axis] <= bound; };
  for (int i = 0; i < in.n; ++i) {
    const Eigen::Vector2d& a = in.v[static_cast<std::size_t>(i)];
    const Eigen::Vector2d& b = in.v[static_cast<std::size_t>((i + 1) % in.n)];
    const bool ia = inside(a), ib = inside(b);
    if (ia) out.v[static_cast<std::size_t>(out.n++)] = a;
    if (ia != ib) {  // the edge crosses the bound (so the bound is finite)
      const double t = (bound - a[axis]) / (b[axis] - a[axis]);
      out.v[static_cast<std::size_t>(out.n++)] = a + t * (b - a);
    }
  }
  return out;
}

double Area(const Polygon& p) {
  double twice = 0.0;
  for (int i = 0; i < p.n; ++i) {
    const Eigen::Vector2d& a = p.v[static_cast<std::size_t>(i)];
    const Eigen::Vector2d& b = p.v[static_cast<std::size_t>((i + 1) % p.n)];
    twice += a.x() * b.y() - a.y() * b.x();
  }
  return 0.5 * std::abs(twice);
}

// Cell index of x along edges: -1 before the first edge, edges.size() - 1 after the last.
int CellIndex(const std::vector<double>& edges, double x) {
  return static_cast<int>(std::upper_bound(edges.begin(), edges.end(), x) - edges.begin()) - 1;
}
double CellLow(const std::vector<double>& edges, int i) {
  return i < 0 ? -kInf : edges[static_cast<std::size_t>(i)];
}
double CellHigh(const std::vector<double>& edges, int i) {
  return i + 1 >= static_cast<int>(edges.size()) ? kInf : edges[static_cast<std::size_t>(i + 1)];
}

// Reflectance of the target's cells (and the outside) as one camera sees them.
class Shader {
 public:
  Shader(const CalibrationTarget& target, const TargetPhotometry& ph, bool facing)
      : t_(target), ph_(ph), facing_(facing) {}

  double Cell(int ix, int iy) const {
    if (ix < 0 || iy < 0 || ix >= t_.num_cells_x() || iy >= t_.num_cells_y()) return ph_.background_reflectance;
    if (!facing_) return ph_.back_reflectance;
    return t_.IsBlack(ix, iy) ? ph_.black_reflectance : ph_.white_reflectance;
  }

  double Point(const Eigen::Vector2d& p) const {
    return Cell(CellIndex(t_.x_edges(), p.x()), CellIndex(t_.y_edges(), p.y()));
  }

  // Mean reflectance over the footprint quadrilateral q (4 points on the plane, in order).
  double Footprint(const Polygon& q) const {
    double x_min = q.v[0].x(), x_max = x_min, y_min = q.v[0].y(), y_max = y_min;
    for (int i = 1; i < 4; ++i) {
      const Eigen::Vector2d& p = q.v[static_cast<std::size_t>(i)];
      x_min = std::min(x_min, p.x());
      x_max = std::max(x_max, p.x());
      y_min = std::min(y_min, p.y());
      y_max = std::max(y_max, p.y());
    }
    const int ix0 = CellIndex(t_.x_edges(), x_min), ix1 = CellIndex(t_.x_edges(), x_max);
    const int iy0 = CellIndex(t_.y_edges(), y_min), iy1 = CellIndex(t_.y_edges(), y_max);
    if (ix0 == ix1 && iy0 == iy1) return Cell(ix0, iy0);
    if ((ix1 - ix0 + 1) * (iy1 - iy0 + 1) > kMaxClipCells) return Sampled(q);
    double weighted = 0.0, total = 0.0;
    for (int ix = ix0; ix <= ix1; ++ix) {
      const Polygon strip = Clip(Clip(q, 0, CellLow(t_.x_edges(), ix), true), 0, CellHigh(t_.x_edges(), ix), false);
      if (strip.n < 3) continue;
      for (int iy = iy0; iy <= iy1; ++iy) {
        const double a =
            Area(Clip(Clip(strip, 1, CellLow(t_.y_edges(), iy), true), 1, CellHigh(t_.y_edges(), iy), false));
        weighted += a * Cell(ix, iy);
        total += a;
      }
    }
    return total > 0.0 ? weighted / total : Point(q.v[0]);
  }

 private:
  // Bilinear point samples over the footprint (only for footprints too large to resolve).
  double Sampled(const Polygon& q) const {
    double sum = 0.0;
    for (int j = 0; j < kFallbackSamples; ++j) {
      const double b = (j + 0.5) / kFallbackSamples;
      for (int i = 0; i < kFallbackSamples; ++i) {
        const double a = (i + 0.5) / kFallbackSamples;
        sum += Point((1 - b) * ((1 - a) * q.v[0] + a * q.v[1]) + b * ((1 - a) * q.v[3] + a * q.v[2]));
      }
    }
    return sum / (kFallbackSamples * kFallbackSamples);
  }

  const CalibrationTarget& t_;
  const TargetPhotometry& ph_;
  bool facing_;
};

double VignettingFactor(const TargetPhotometry& ph, const Eigen::Vector2d& x_n) {
  const double r2 = x_n.squaredNorm();
  switch (ph.vignetting) {
    case Vignetting::kNone: return 1.0;
    case Vignetting::kCos4: return 1.0 / ((1.0 + r2) * (1.0 + r2));
    case Vignetting::kPolynomial: {
      const auto& c = ph.vignetting_coeffs;
      return std::max(0.0, 1.0 + r2 * (c[0] + r2 * (c[1] + r2 * c[2])));
    }
  }
  return 1.0;
}

void ValidatePhotometry(const TargetPhotometry& ph) {
  for (double x : {ph.illumination_e, ph.white_reflectance, ph.black_reflectance, ph.background_reflectance,
                   ph.back_reflectance, ph.blur_sigma_px})
    if (!(x >= 0.0) || !std::isfinite(x)) throw std::invalid_argument("render: photometry values must be finite and >= 0");
  for (double c : ph.vignetting_coeffs)
    if (!std::isfinite(c)) throw std::invalid_argument("render: vignetting coefficients must be finite");
}

void ValidatePose(const CameraPose& pose) {
  if (!pose.C_k_w.allFinite() || !pose.r_w_wk.allFinite() || !IsRotation(pose.C_k_w, 1e-6))
    throw std::invalid_argument("render: camera pose must be a finite rotation and position");
}

}  // namespace

CameraPose LookAt(const Eigen::Vector3d& eye_w, const Eigen::Vector3d& look_at_w, const Eigen::Vector3d& down_w) {
  const Eigen::Vector3d axis = look_at_w - eye_w;
  if (!(axis.norm() > 0.0)) throw std::invalid_argument("LookAt: eye and look-at point coincide");
  const Eigen::Vector3d z = axis.normalized();
  const Eigen::Vector3d down = down_w - down_w.dot(z) * z;
  if (!(down.norm() > 1e-9 * down_w.norm()) || !(down_w.norm() > 0.0))
    throw std::invalid_argument("LookAt: down direction parallel to the optic axis");
  const Eigen::Vector3d y = down.normalized();
  const Eigen::Vector3d x = y.cross(z);  // right-handed camera: x = y cross z
  CameraPose pose;
  pose.C_k_w.row(0) = x.transpose();
  pose.C_k_w.row(1) = y.transpose();
  pose.C_k_w.row(2) = z.transpose();
  pose.r_w_wk = eye_w;
  return pose;
}

TargetRenderer::TargetRenderer(const CameraIntrinsics& cam) : cam_(cam) {
  if (cam.width <= 0 || cam.height <= 0 || !(cam.alpha_x > 0.0) || !(cam.alpha_y > 0.0))
    throw std::invalid_argument("TargetRenderer: camera needs a positive image size and focal length");
  const int w = cam.width + 1, h = cam.height + 1;
  corner_rays_.resize(static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      Eigen::Vector2d x_n;
      const bool ok = Unproject(cam, Eigen::Vector2d(u - 0.5, v - 0.5), &x_n) == UnprojectStatus::kOk;
      corner_rays_[static_cast<std::size_t>(v) * static_cast<std::size_t>(w) + static_cast<std::size_t>(u)] =
          ok ? x_n : Eigen::Vector2d(kNaN, kNaN);
    }
  }
}

cv::Mat TargetRenderer::RenderSignal(const CalibrationTarget& target, const CameraPose& pose,
                                     const TargetPhotometry& photometry) const {
  ValidatePose(pose);
  ValidatePhotometry(photometry);
  const Shader shader(target, photometry, pose.r_w_wk.z() > 0.0);
  const Eigen::Matrix3d C_w_k = pose.C_k_w.transpose();
  const Eigen::Vector3d& o = pose.r_w_wk;
  const int w = cam_.width + 1;

  // Where one row of pixel-corner rays meets the plane z = 0 (NaN where it does not).
  auto intersect_row = [&](int v, std::vector<Eigen::Vector2d>* out) {
    for (int u = 0; u < w; ++u) {
      const Eigen::Vector2d& x_n = corner_rays_[static_cast<std::size_t>(v * w + u)];
      const Eigen::Vector3d d = C_w_k * Eigen::Vector3d(x_n.x(), x_n.y(), 1.0);
      const double lambda = -o.z() / d.z();
      (*out)[static_cast<std::size_t>(u)] =
          lambda > 0.0 && std::isfinite(lambda) ? Eigen::Vector2d(o.x() + lambda * d.x(), o.y() + lambda * d.y())
                                                : Eigen::Vector2d(kNaN, kNaN);
    }
  };

  cv::Mat signal(cam_.height, cam_.width, CV_64FC1);
  std::vector<Eigen::Vector2d> top(static_cast<std::size_t>(w)), bottom(static_cast<std::size_t>(w));
  intersect_row(0, &top);
  for (int v = 0; v < cam_.height; ++v) {
    intersect_row(v + 1, &bottom);
    double* row = signal.ptr<double>(v);
    for (int u = 0; u < cam_.width; ++u) {
      const std::size_t i = static_cast<std::size_t>(u);
      Polygon q;
      q.n = 4;
      q.v = {top[i], top[i + 1], bottom[i + 1], bottom[i]};
      const bool hits = q.v[0].allFinite() && q.v[1].allFinite() && q.v[2].allFinite() && q.v[3].allFinite();
      const double reflectance = hits ? shader.Footprint(q) : photometry.background_reflectance;
      // The pixel centre's ray, for vignetting: the mean of its corners' rays.
      const std::size_t c = static_cast<std::size_t>(v * w + u);
      Eigen::Vector2d x_n = 0.25 * (corner_rays_[c] + corner_rays_[c + 1] + corner_rays_[c + static_cast<std::size_t>(w)] +
                                    corner_rays_[c + static_cast<std::size_t>(w) + 1]);
      if (!x_n.allFinite()) x_n.setZero();
      row[u] = photometry.illumination_e * reflectance * VignettingFactor(photometry, x_n);
    }
    std::swap(top, bottom);
  }
  if (photometry.blur_sigma_px > 0.0)
    cv::GaussianBlur(signal, signal, cv::Size(0, 0), photometry.blur_sigma_px, photometry.blur_sigma_px,
                     cv::BORDER_REPLICATE);
  return signal;
}

cv::Mat TargetRenderer::Render(const CalibrationTarget& target, const CameraPose& pose,
                               const TargetPhotometry& photometry, const SensorModel& sensor,
                               std::mt19937_64* rng) const {
  ValidateSensor(sensor);
  return ApplySensor(RenderSignal(target, pose, photometry), sensor, rng);
}

std::vector<CornerTruth> TargetRenderer::Corners(const CalibrationTarget& target, const CameraPose& pose,
                                                 double margin_px) const {
  ValidatePose(pose);
  const bool facing = pose.r_w_wk.z() > 0.0;
  std::vector<CornerTruth> out;
  out.reserve(target.corners().size());
  for (const TargetCorner& corner : target.corners()) {
    CornerTruth truth{corner, ProjectVisible(cam_, pose.C_k_w * (corner.P_w - pose.r_w_wk), margin_px)};
    truth.projection.visible = truth.projection.visible && facing;
    out.push_back(truth);
  }
  return out;
}

}  // namespace mfns::host
