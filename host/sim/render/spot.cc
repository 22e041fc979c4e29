#include "host/sim/render/spot.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace mfns::host {
namespace {

constexpr double kSpotExtentSigmas = 8.0;

void CheckSignal(const cv::Mat* signal_e) {
  if (signal_e == nullptr || signal_e->empty() || signal_e->type() != CV_64FC1)
    throw std::invalid_argument("render: signal must be a non-empty CV_64FC1 image");
}

// Standard normal CDF.
double Phi(double x) { return 0.5 * std::erfc(-x * 0.7071067811865475244); }

// Fractions of a 1-D Gaussian (centre c, sigma s) falling in pixels first..last (inclusive).
std::vector<double> PixelFractions(double c, double s, int first, int last) {
  std::vector<double> f(static_cast<std::size_t>(last - first + 1));
  double lower = Phi((first - 0.5 - c) / s);
  for (int i = first; i <= last; ++i) {
    const double upper = Phi((i + 0.5 - c) / s);
    f[static_cast<std::size_t>(i - first)] = upper - lower;
    lower = upper;
  }
  return f;
}

// floor(x) or ceil(x) as an int clamped to [lo, hi] (no overflow for huge or infinite x).
int FloorClamped(double x, int lo, int hi) { return static_cast<int>(std::clamp(std::floor(x), double(lo), double(hi))); }
int CeilClamped(double x, int lo, int hi) { return static_cast<int>(std::clamp(std::ceil(x), double(lo), double(hi))); }

// Pixel range [first, last] (inclusive, inside an image of n pixels) touched by [a, b];
// empty (first > last) when it misses the image.
void PixelRange(double a, double b, int n, int* first, int* last) {
  *first = FloorClamped(a, 0, n);
  *last = CeilClamped(b, -1, n - 1);
}

// Overlap of [a, b] with pixel i's span [i - .5, i + .5].
double Overlap1d(double a, double b, int i) {
  return std::max(0.0, std::min(b, i + 0.5) - std::max(a, i - 0.5));
}

}  // namespace

void AddGaussianSpot(const GaussianSpot& spot, cv::Mat* signal_e) {
  CheckSignal(signal_e);
  if (!(spot.sigma_px > 0.0) || !std::isfinite(spot.sigma_px))
    throw std::invalid_argument("render: spot sigma_px must be > 0");
  if (!(spot.flux_e >= 0.0) || !std::isfinite(spot.flux_e))
    throw std::invalid_argument("render: spot flux_e must be >= 0");
  if (!spot.uv_px.allFinite()) throw std::invalid_argument("render: spot centre not finite");
  const double reach = kSpotExtentSigmas * spot.sigma_px + 1.0;
  int u0, u1, v0, v1;
  PixelRange(spot.uv_px.x() - reach, spot.uv_px.x() + reach, signal_e->cols, &u0, &u1);
  PixelRange(spot.uv_px.y() - reach, spot.uv_px.y() + reach, signal_e->rows, &v0, &v1);
  if (u0 > u1 || v0 > v1) return;
  const std::vector<double> fu = PixelFractions(spot.uv_px.x(), spot.sigma_px, u0, u1);
  const std::vector<double> fv = PixelFractions(spot.uv_px.y(), spot.sigma_px, v0, v1);
  for (int v = v0; v <= v1; ++v) {
    double* row = signal_e->ptr<double>(v);
    const double wv = spot.flux_e * fv[static_cast<std::size_t>(v - v0)];
    for (int u = u0; u <= u1; ++u) row[u] += wv * fu[static_cast<std::size_t>(u - u0)];
  }
}

double FluxForPeak(double peak_e, double sigma_px) {
  const double f = Phi(0.5 / sigma_px) - Phi(-0.5 / sigma_px);
  return peak_e / (f * f);
}

ProjectedPoint AddBeaconSpot(const CameraIntrinsics& cam, const Eigen::Vector3d& p_k,
                             const BeaconAppearance& appearance, cv::Mat* signal_e, double margin_px) {
  const ProjectedPoint truth = ProjectVisible(cam, p_k, margin_px);
  // Drawn when its centre is within the spot's reach of the image and not a distortion
  // ghost (a point outside the field of view folded into the image); farther spots add nothing.
  const double reach = kSpotExtentSigmas * appearance.sigma_px + 1.0;
  if (truth.status == ProjectStatus::kOk && ProjectVisible(cam, p_k, -reach).visible)
    AddGaussianSpot({truth.uv_px, appearance.sigma_px, appearance.flux_e}, signal_e);
  return truth;
}

void AddBrightRectangle(const BrightRectangle& rect, cv::Mat* signal_e) {
  CheckSignal(signal_e);
  if (!std::isfinite(rect.u_min) || !std::isfinite(rect.u_max) || !std::isfinite(rect.v_min) ||
      !std::isfinite(rect.v_max) || !(rect.level_e >= 0.0) || !std::isfinite(rect.level_e))
    throw std::invalid_argument("render: rectangle must be finite with level_e >= 0");
  int u0, u1, v0, v1;
  PixelRange(rect.u_min + 0.5, rect.u_max - 0.5, signal_e->cols, &u0, &u1);
  PixelRange(rect.v_min + 0.5, rect.v_max - 0.5, signal_e->rows, &v0, &v1);
  for (int v = v0; v <= v1; ++v) {
    const double wv = rect.level_e * Overlap1d(rect.v_min, rect.v_max, v);
    double* row = signal_e->ptr<double>(v);
    for (int u = u0; u <= u1; ++u) row[u] += wv * Overlap1d(rect.u_min, rect.u_max, u);
  }
}

void AddBrightEllipse(const BrightEllipse& e, cv::Mat* signal_e) {
  CheckSignal(signal_e);
  if (!(e.semi_axis_u_px > 0.0) || !(e.semi_axis_v_px > 0.0) || !std::isfinite(e.semi_axis_u_px) ||
      !std::isfinite(e.semi_axis_v_px) || !e.centre_px.allFinite() || !std::isfinite(e.angle_rad) ||
      !(e.level_e >= 0.0) || !std::isfinite(e.level_e))
    throw std::invalid_argument("render: ellipse must be finite with semi-axes > 0 and level_e >= 0");
  const double c = std::cos(e.angle_rad), s = std::sin(e.angle_rad);
  // Inside when q(u, v) <= 1 with q = (a'/A)^2 + (b'/B)^2 in the ellipse's own axes.
  auto q = [&](double u, double v) {
    const double du = u - e.centre_px.x(), dv = v - e.centre_px.y();
    const double a = (c * du + s * dv) / e.semi_axis_u_px, b = (-s * du + c * dv) / e.semi_axis_v_px;
    return a * a + b * b;
  };
  const double reach = std::max(e.semi_axis_u_px, e.semi_axis_v_px) + 1.0;
  int u0, u1, v0, v1;
  PixelRange(e.centre_px.x() - reach, e.centre_px.x() + reach, signal_e->cols, &u0, &u1);
  PixelRange(e.centre_px.y() - reach, e.centre_px.y() + reach, signal_e->rows, &v0, &v1);
  // In the ellipse's scaled frame a pixel (half-diagonal 0.71 px) spans at most this in sqrt(q).
  const double pixel_reach = 0.75 / std::min(e.semi_axis_u_px, e.semi_axis_v_px);
  constexpr int kSub = 8;
  for (int v = v0; v <= v1; ++v) {
    double* row = signal_e->ptr<double>(v);
    for (int u = u0; u <= u1; ++u) {
      const double r = std::sqrt(q(u, v));
      if (r <= 1.0 - pixel_reach) {
        row[u] += e.level_e;
      } else if (r < 1.0 + pixel_reach) {
        int inside = 0;
        for (int j = 0; j < kSub; ++j)
          for (int i = 0; i < kSub; ++i)
            inside += q(u - 0.5 + (i + 0.5) / kSub, v - 0.5 + (j + 0.5) / kSub) <= 1.0 ? 1 : 0;
        row[u] += e.level_e * inside / (kSub * kSub);
      }
    }
  }
}

cv::Mat RenderLedSignal(const CameraIntrinsics& cam, const LedFrameSpec& spec,
                        std::vector<BeaconTruth>* truth) {
  if (cam.width <= 0 || cam.height <= 0) throw std::invalid_argument("render: camera has no image size");
  cv::Mat signal(cam.height, cam.width, CV_64FC1, cv::Scalar(std::max(0.0, spec.background_e)));
  if (truth != nullptr) truth->clear();
  for (const BeaconInView& b : spec.beacons) {
    const ProjectedPoint p = AddBeaconSpot(cam, b.p_k, b.appearance, &signal, spec.margin_px);
    if (truth != nullptr) truth->push_back({b.id, p});
  }
  for (const GaussianSpot& s : spec.reflections) AddGaussianSpot(s, &signal);
  for (const BrightRectangle& r : spec.rectangles) AddBrightRectangle(r, &signal);
  for (const BrightEllipse& e : spec.ellipses) AddBrightEllipse(e, &signal);
  return signal;
}

LedFrame RenderLedFrame(const CameraIntrinsics& cam, const LedFrameSpec& spec,
                        const SensorModel& sensor, std::mt19937_64* rng) {
  ValidateSensor(sensor);
  LedFrame frame;
  if (spec.blank) {
    if (cam.width <= 0 || cam.height <= 0) throw std::invalid_argument("render: camera has no image size");
    frame.image = cv::Mat::zeros(cam.height, cam.width, sensor.bit_depth == 8 ? CV_8UC1 : CV_16UC1);
    return frame;
  }
  const cv::Mat signal = RenderLedSignal(cam, spec, &frame.truth);
  frame.image = ApplySensor(signal, sensor, rng);
  return frame;
}

}  // namespace mfns::host
