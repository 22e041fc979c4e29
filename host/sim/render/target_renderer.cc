#include "host/sim/render/target_renderer.h"

#include <algorithm>
#include <array>
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

// A point of the target plane (x, y), NaN where a ray misses it.
struct PlanePoint {
  double x, y;
};

// A polygon with room for a quadrilateral clipped by 4 half-planes: 8 vertices when it is
// convex (one more per clip); a footprint twisted by a distortion fold can need more, up to
// 20; Clip never writes past the end.
struct Polygon {
  static constexpr int kCapacity = 32;
  std::array<Eigen::Vector2d, kCapacity> v;
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
    if (out.n + 2 > Polygon::kCapacity) break;
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

  // Mean reflectance over the footprint quadrilateral a, b, c, d (points on the plane, in
  // order around the pixel). Plain doubles on the common path: it runs for every pixel.
  double Footprint(const PlanePoint& a, const PlanePoint& b, const PlanePoint& c, const PlanePoint& d) {
    const double x_min = std::min(std::min(a.x, b.x), std::min(c.x, d.x));
    const double x_max = std::max(std::max(a.x, b.x), std::max(c.x, d.x));
    const double y_min = std::min(std::min(a.y, b.y), std::min(c.y, d.y));
    const double y_max = std::max(std::max(a.y, b.y), std::max(c.y, d.y));
    int ix0, ix1, iy0, iy1;
    Range(t_.x_edges(), x_min, x_max, &last_ix_, &ix0, &ix1);
    Range(t_.y_edges(), y_min, y_max, &last_iy_, &iy0, &iy1);
    if (ix0 == ix1 && iy0 == iy1) return Cell(ix0, iy0);
    Polygon q;
    q.n = 4;
    q.v[0] = {a.x, a.y};
    q.v[1] = {b.x, b.y};
    q.v[2] = {c.x, c.y};
    q.v[3] = {d.x, d.y};
    if ((ix1 - ix0 + 1) * (iy1 - iy0 + 1) > kMaxClipCells) return Sampled(q);
    double weighted = 0.0, total = 0.0;
    for (int ix = ix0; ix <= ix1; ++ix) {
      const Polygon strip = Clip(Clip(q, 0, CellLow(t_.x_edges(), ix), true), 0, CellHigh(t_.x_edges(), ix), false);
      if (strip.n < 3) continue;
      for (int iy = iy0; iy <= iy1; ++iy) {
        const double area =
            Area(Clip(Clip(strip, 1, CellLow(t_.y_edges(), iy), true), 1, CellHigh(t_.y_edges(), iy), false));
        weighted += area * Cell(ix, iy);
        total += area;
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

  // Cells [first, last] spanned by [lo, hi] along one axis. Neighbouring pixels mostly fall in
  // the same cell, so the last single cell is tried before the binary search.
  static void Range(const std::vector<double>& edges, double lo, double hi, int* hint, int* first, int* last) {
    if (CellLow(edges, *hint) <= lo && hi < CellHigh(edges, *hint)) {
      *first = *last = *hint;
      return;
    }
    *first = CellIndex(edges, lo);
    *last = CellIndex(edges, hi);
    if (*first == *last) *hint = *first;
  }

  const CalibrationTarget& t_;
  const TargetPhotometry& ph_;
  bool facing_;
  int last_ix_ = -1, last_iy_ = -1;
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
  Shader shader(target, photometry, pose.r_w_wk.z() > 0.0);
  const Eigen::Matrix3d C_w_k = pose.C_k_w.transpose();
  const double ox = pose.r_w_wk.x(), oy = pose.r_w_wk.y(), oz = pose.r_w_wk.z();
  const int w = cam_.width + 1;

  // Where one row of pixel-corner rays meets the plane z = 0 (NaN where it does not): the
  // ray C_w_k (x, y, 1) from the camera centre o reaches z = 0 at o + lambda ray.
  auto intersect_row = [&](int v, std::vector<PlanePoint>* out) {
    const Eigen::Vector2d* rays = &corner_rays_[static_cast<std::size_t>(v) * static_cast<std::size_t>(w)];
    for (std::size_t u = 0; u < static_cast<std::size_t>(w); ++u) {
      const double x = rays[u].x(), y = rays[u].y();
      const double dx = C_w_k(0, 0) * x + C_w_k(0, 1) * y + C_w_k(0, 2);
      const double dy = C_w_k(1, 0) * x + C_w_k(1, 1) * y + C_w_k(1, 2);
      const double dz = C_w_k(2, 0) * x + C_w_k(2, 1) * y + C_w_k(2, 2);
      const double lambda = -oz / dz;
      (*out)[u] = lambda > 0.0 && std::isfinite(lambda) ? PlanePoint{ox + lambda * dx, oy + lambda * dy}
                                                        : PlanePoint{kNaN, kNaN};
    }
  };
  auto hits = [](const PlanePoint& p) { return !std::isnan(p.x); };  // finite whenever not NaN

  cv::Mat signal(cam_.height, cam_.width, CV_64FC1);
  std::vector<PlanePoint> top(static_cast<std::size_t>(w)), bottom(static_cast<std::size_t>(w));
  intersect_row(0, &top);
  for (int v = 0; v < cam_.height; ++v) {
    intersect_row(v + 1, &bottom);
    double* row = signal.ptr<double>(v);
    for (int u = 0; u < cam_.width; ++u) {
      const std::size_t i = static_cast<std::size_t>(u);
      const bool all_hit = hits(top[i]) && hits(top[i + 1]) && hits(bottom[i + 1]) && hits(bottom[i]);
      row[u] = photometry.illumination_e *
               (all_hit ? shader.Footprint(top[i], top[i + 1], bottom[i + 1], bottom[i]) : photometry.background_reflectance);
    }
    std::swap(top, bottom);
  }
  if (photometry.vignetting != Vignetting::kNone) ApplyVignetting(photometry, &signal);
  if (photometry.blur_sigma_px > 0.0)
    cv::GaussianBlur(signal, signal, cv::Size(0, 0), photometry.blur_sigma_px, photometry.blur_sigma_px,
                     cv::BORDER_REPLICATE);
  return signal;
}

void TargetRenderer::ApplyVignetting(const TargetPhotometry& photometry, cv::Mat* signal) const {
  const std::size_t w = static_cast<std::size_t>(cam_.width) + 1;
  for (int v = 0; v < cam_.height; ++v) {
    double* row = signal->ptr<double>(v);
    for (int u = 0; u < cam_.width; ++u) {
      // The pixel centre's ray: the mean of its corners' rays (exact to second order).
      const std::size_t c = static_cast<std::size_t>(v) * w + static_cast<std::size_t>(u);
      Eigen::Vector2d x_n = 0.25 * (corner_rays_[c] + corner_rays_[c + 1] + corner_rays_[c + w] + corner_rays_[c + w + 1]);
      if (!x_n.allFinite()) x_n.setZero();
      row[u] *= VignettingFactor(photometry, x_n);
    }
  }
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
