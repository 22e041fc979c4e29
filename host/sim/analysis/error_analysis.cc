#include "host/sim/analysis/error_analysis.h"

#include <algorithm>
#include <array>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>

#include "common/rotation/rotation.h"

namespace mfns::host {
namespace {

// The nominal geometry of the paper's simplification (module comment): eq. 2 with these terms.
const Eigen::Matrix3d kC_b_w = Eigen::Matrix3d::Identity();
const Eigen::Vector3d kR_b_bw = Eigen::Vector3d::Zero();
const EulerAngles kEuler_z_b{};  // C_z_b = I
const Eigen::Vector3d kR_b_bz = Eigen::Vector3d::Zero();

// Random numbers with a fully specified sequence (mt19937_64 is fixed by the standard; the
// standard distributions are not), so a seed gives the same CSV with any standard library.
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : engine_(seed) {}
  // Uniform in [0, 1) with 53 random bits.
  double Uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  // Standard normal by Box-Muller; the second value of each pair is kept for the next call.
  double Normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double r = std::sqrt(-2.0 * std::log(1.0 - Uniform()));  // 1 - U in (0, 1]
    const double a = 2.0 * kPi * Uniform();
    spare_ = r * std::sin(a);
    has_spare_ = true;
    return r * std::cos(a);
  }

 private:
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

// SplitMix64 finaliser: decorrelates the streams of neighbouring (seed, figure, point) keys.
std::uint64_t Mix(std::uint64_t z) {
  z += 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

std::uint64_t PointSeed(std::uint64_t seed, ErrorFigure f, int point_index) {
  return Mix(Mix(Mix(seed) ^ static_cast<std::uint64_t>(f)) ^ static_cast<std::uint64_t>(point_index));
}

// d(EulerToMatrix(e))/d(phi, theta, psi) for C = R3(psi) R1(phi) R2(theta).
std::array<Eigen::Matrix3d, 3> EulerMatrixDerivatives(const EulerAngles& e) {
  const auto dR1 = [](double a) {
    const double c = std::cos(a), s = std::sin(a);
    Eigen::Matrix3d d;
    d << 0, 0, 0, 0, -s, c, 0, -c, -s;
    return d;
  };
  const auto dR2 = [](double a) {
    const double c = std::cos(a), s = std::sin(a);
    Eigen::Matrix3d d;
    d << -s, 0, -c, 0, 0, 0, c, 0, -s;
    return d;
  };
  const auto dR3 = [](double a) {
    const double c = std::cos(a), s = std::sin(a);
    Eigen::Matrix3d d;
    d << -s, c, 0, -c, -s, 0, 0, 0, 0;
    return d;
  };
  return {R3(e.psi) * dR1(e.phi) * R2(e.theta), R3(e.psi) * R1(e.phi) * dR2(e.theta),
          dR3(e.psi) * R1(e.phi) * R2(e.theta)};
}

EulerAngles Plus(const EulerAngles& a, const Eigen::Vector3d& d) {
  return {a.phi + d.x(), a.theta + d.y(), a.psi + d.z()};
}

// Gauss-Legendre nodes and weights on [-1, 1] (Newton on P_n, Numerical Recipes' gauleg).
struct GaussLegendre {
  std::vector<double> x, w;
};

GaussLegendre MakeGaussLegendre(int n) {
  GaussLegendre g;
  g.x.resize(static_cast<std::size_t>(n));
  g.w.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < (n + 1) / 2; ++i) {
    double z = std::cos(kPi * (i + 0.75) / (n + 0.5));
    double dp = 1.0;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1.0, p1 = 0.0;
      for (int j = 0; j < n; ++j) {
        const double p2 = p1;
        p1 = p0;
        p0 = ((2.0 * j + 1.0) * z * p1 - j * p2) / (j + 1.0);
      }
      dp = n * (z * p0 - p1) / (z * z - 1.0);
      const double dz = p0 / dp;
      z -= dz;
      if (std::abs(dz) < 1e-15) break;
    }
    const auto a = static_cast<std::size_t>(i), b = static_cast<std::size_t>(n - 1 - i);
    g.x[a] = -z;
    g.x[b] = z;
    g.w[a] = g.w[b] = 2.0 / ((1.0 - z * z) * dp * dp);
  }
  return g;
}

// Image bounds as ratios X/Z, Y/Z (no distortion, no skew): u in [-0.5, W - 0.5] etc.
struct ViewRatios {
  double x_lo, x_hi, y_lo, y_hi;
};

ViewRatios Ratios(const CameraIntrinsics& c) {
  return {(-0.5 - c.u0) / c.alpha_x, (c.width - 0.5 - c.u0) / c.alpha_x, (-0.5 - c.v0) / c.alpha_y,
          (c.height - 0.5 - c.v0) / c.alpha_y};
}

// The kept interval of X (or Y) at depth z: the box range, cut to the view when gated.
std::pair<double, double> KeptInterval(const AnalysisSetup& s, const Eigen::Vector2d& range, double r_lo,
                                       double r_hi, double z) {
  if (!s.fov_gate) return {range[0], range[1]};
  return {std::max(range[0], r_lo * z), std::min(range[1], r_hi * z)};
}

// Integral over the kept region of f(P) (and of 1 in *volume). The kept region is, for each
// depth, a rectangle whose sides are linear in depth between the breakpoints where a view
// bound crosses a box bound; Gauss-Legendre per piece integrates it to rounding.
template <typename F>
double IntegrateKept(const AnalysisSetup& s, const F& f, double* volume) {
  const double z_lo = std::max(s.z_range[0], s.min_depth), z_hi = s.z_range[1];
  *volume = 0.0;
  if (!(z_hi > z_lo)) return 0.0;
  const ViewRatios r = Ratios(s.camera);
  std::vector<double> cuts{z_lo, z_hi};
  if (s.fov_gate) {
    for (const double c : {s.x_range[0], s.x_range[1]})
      for (const double a : {r.x_lo, r.x_hi}) cuts.push_back(c / a);
    for (const double c : {s.y_range[0], s.y_range[1]})
      for (const double a : {r.y_lo, r.y_hi}) cuts.push_back(c / a);
  }
  std::erase_if(cuts, [&](double z) { return !std::isfinite(z) || z < z_lo || z > z_hi; });
  std::sort(cuts.begin(), cuts.end());

  static const GaussLegendre gz = MakeGaussLegendre(32), gxy = MakeGaussLegendre(8);
  double sum = 0.0, vol = 0.0;
  for (std::size_t k = 0; k + 1 < cuts.size(); ++k) {
    const double za = cuts[k], zb = cuts[k + 1];
    if (!(zb > za)) continue;
    for (std::size_t iz = 0; iz < gz.x.size(); ++iz) {
      const double z = 0.5 * (za + zb) + 0.5 * (zb - za) * gz.x[iz];
      const double wz = 0.5 * (zb - za) * gz.w[iz];
      const auto [xa, xb] = KeptInterval(s, s.x_range, r.x_lo, r.x_hi, z);
      const auto [ya, yb] = KeptInterval(s, s.y_range, r.y_lo, r.y_hi, z);
      if (!(xb > xa) || !(yb > ya)) continue;
      vol += wz * (xb - xa) * (yb - ya);
      for (std::size_t ix = 0; ix < gxy.x.size(); ++ix) {
        const double x = 0.5 * (xa + xb) + 0.5 * (xb - xa) * gxy.x[ix];
        const double wx = 0.5 * (xb - xa) * gxy.w[ix];
        for (std::size_t iy = 0; iy < gxy.x.size(); ++iy) {
          const double y = 0.5 * (ya + yb) + 0.5 * (yb - ya) * gxy.x[iy];
          const double wy = 0.5 * (yb - ya) * gxy.w[iy];
          sum += wz * wx * wy * f(Eigen::Vector3d(x, y, z));
        }
      }
    }
  }
  *volume = vol;
  return sum;
}

double BoxVolume(const AnalysisSetup& s) {
  return (s.x_range[1] - s.x_range[0]) * (s.y_range[1] - s.y_range[0]) * (s.z_range[1] - s.z_range[0]);
}

// The smallest axis-aligned box holding every keepable beacon: the beacon box cut to depths
// >= min_depth and, when gated, to the view cone's extent over those depths. Drawing uniformly
// in it and rejecting with KeepBeacon is still uniform over the kept region, with ~10x fewer
// rejections than drawing in the whole box (Table 1 keeps 4% of the box).
struct Box {
  Eigen::Vector3d lo, hi;
  double Volume() const { return (hi - lo).prod(); }
};

Box SamplingBox(const AnalysisSetup& s) {
  Box b{{s.x_range[0], s.y_range[0], std::max(s.z_range[0], s.min_depth)}, {s.x_range[1], s.y_range[1], s.z_range[1]}};
  if (s.fov_gate) {
    const ViewRatios r = Ratios(s.camera);
    const double za = b.lo.z(), zb = b.hi.z();  // cone extent is linear in depth: check both ends
    b.lo.x() = std::max(b.lo.x(), std::min(r.x_lo * za, r.x_lo * zb));
    b.hi.x() = std::min(b.hi.x(), std::max(r.x_hi * za, r.x_hi * zb));
    b.lo.y() = std::max(b.lo.y(), std::min(r.y_lo * za, r.y_lo * zb));
    b.hi.y() = std::min(b.hi.y(), std::max(r.y_hi * za, r.y_hi * zb));
  }
  return b;
}

Eigen::Vector3d DrawError(Rng& rng, ErrorDraw d, double m) {
  Eigen::Vector3d n(rng.Normal(), rng.Normal(), rng.Normal());
  if (d == ErrorDraw::kSphere) {
    while (n.norm() < 1e-12) n = Eigen::Vector3d(rng.Normal(), rng.Normal(), rng.Normal());
    n.normalize();  // a normalised isotropic Gaussian is uniform on the sphere
  }
  return m * n;
}

}  // namespace

const char* ToString(ErrorFigure f) {
  switch (f) {
    case ErrorFigure::kBeaconPosition: return "beacon-position";
    case ErrorFigure::kCameraPosition: return "camera-position";
    case ErrorFigure::kCameraAttitude: return "camera-attitude";
  }
  return "unknown";
}

const char* ToString(ErrorDraw d) {
  switch (d) {
    case ErrorDraw::kGaussian: return "gaussian";
    case ErrorDraw::kSphere: return "sphere";
  }
  return "unknown";
}

AnalysisSetup PaperTable1Setup() {
  AnalysisSetup s;
  s.camera.width = 1280;
  s.camera.height = 1024;
  s.camera.alpha_x = 1600.0;
  s.camera.alpha_y = 1600.0;
  s.camera.u0 = 640.0;
  s.camera.v0 = 512.0;
  return s;
}

void ValidateSetup(const AnalysisSetup& s) {
  const auto check_range = [](const Eigen::Vector2d& r, const char* name) {
    if (!r.allFinite() || !(r[1] > r[0]))
      throw std::invalid_argument(std::string("beacon ") + name + " range must be finite with min < max");
  };
  check_range(s.x_range, "X");
  check_range(s.y_range, "Y");
  check_range(s.z_range, "Z");
  if (!std::isfinite(s.min_depth) || s.min_depth < 0.0)
    throw std::invalid_argument("minimum depth must be finite and >= 0");
  const CameraIntrinsics& c = s.camera;
  if (c.width <= 0 || c.height <= 0 || !(c.alpha_x > 0.0) || !(c.alpha_y > 0.0))
    throw std::invalid_argument("camera needs a positive size and focal lengths");
  if (c.skew != 0.0 || std::any_of(c.kc.begin(), c.kc.end(), [](double k) { return k != 0.0; }))
    throw std::invalid_argument("the analysis camera must have no skew and no distortion (Table 1)");
  if (KeptFraction(s) < 1e-4)
    throw std::invalid_argument(
        "fewer than 1e-4 of the beacon box is in front of the camera (beyond the minimum depth) and in view");
}

bool KeepBeacon(const AnalysisSetup& s, const Eigen::Vector3d& P_w) {
  static const Eigen::Matrix3d C_z_b = EulerToMatrix(kEuler_z_b);
  const Eigen::Vector3d p_z = C_z_b * (kC_b_w * P_w + kR_b_bw - kR_b_bz);
  if (!(p_z.z() >= s.min_depth) || !(p_z.z() > 0.0)) return false;
  if (!s.fov_gate) return true;
  Eigen::Vector2d uv;
  return Project(s.camera, p_z, &uv) == ProjectStatus::kOk && InImage(s.camera, uv);
}

bool PerturbedU(const AnalysisSetup& s, ErrorFigure f, const Eigen::Vector3d& P_w, const Eigen::Vector3d& e,
                double* u_px) {
  Eigen::Vector3d P = P_w, r_b_bz = kR_b_bz;
  EulerAngles euler = kEuler_z_b;
  switch (f) {
    case ErrorFigure::kBeaconPosition: P += e; break;
    case ErrorFigure::kCameraPosition: r_b_bz += e; break;
    case ErrorFigure::kCameraAttitude: euler = Plus(euler, e); break;
  }
  const Eigen::Vector3d p_z = EulerToMatrix(euler) * (kC_b_w * P + kR_b_bw - r_b_bz);  // eq. 2
  Eigen::Vector2d uv;
  if (Project(s.camera, p_z, &uv) != ProjectStatus::kOk) return false;
  *u_px = uv.x();
  return true;
}

Eigen::RowVector3d GradientU(const AnalysisSetup& s, ErrorFigure f, const Eigen::Vector3d& P_w) {
  const Eigen::Matrix3d C_z_b = EulerToMatrix(kEuler_z_b);
  const Eigen::Vector3d q = kC_b_w * P_w + kR_b_bw - kR_b_bz;  // beacon relative to camera, body axes
  Eigen::Vector2d uv;
  Eigen::Matrix<double, 2, 3> J_uv_p;
  if (Project(s.camera, C_z_b * q, &uv, &J_uv_p) != ProjectStatus::kOk)
    throw std::invalid_argument("gradient asked for a beacon with no image");
  const Eigen::RowVector3d J_u_p = J_uv_p.row(0);
  switch (f) {
    case ErrorFigure::kBeaconPosition: return J_u_p * C_z_b * kC_b_w;
    case ErrorFigure::kCameraPosition: return -J_u_p * C_z_b;
    case ErrorFigure::kCameraAttitude: {
      const std::array<Eigen::Matrix3d, 3> dC = EulerMatrixDerivatives(kEuler_z_b);
      return {J_u_p * dC[0] * q, J_u_p * dC[1] * q, J_u_p * dC[2] * q};
    }
  }
  return Eigen::RowVector3d::Zero();
}

double KeptFraction(const AnalysisSetup& s) {
  double volume = 0.0;
  IntegrateKept(s, [](const Eigen::Vector3d&) { return 0.0; }, &volume);
  return volume / BoxVolume(s);
}

double AnalyticSlope(const AnalysisSetup& s, ErrorFigure f) {
  ValidateSetup(s);
  // E[(g e)^2] = g Sigma g^T: Sigma = I for per-axis unit sigma, I/3 for a random unit vector.
  const double per_axis = s.draw == ErrorDraw::kGaussian ? 1.0 : 1.0 / 3.0;
  double volume = 0.0;
  const double integral = IntegrateKept(
      s, [&](const Eigen::Vector3d& P) { return GradientU(s, f, P).squaredNorm(); }, &volume);
  return std::sqrt(per_axis * integral / volume);
}

PointResult RunPoint(const AnalysisSetup& s, ErrorFigure f, double magnitude, std::int64_t trials,
                     std::uint64_t seed, int point_index) {
  ValidateSetup(s);
  if (trials < 1) throw std::invalid_argument("trials must be >= 1");
  if (!std::isfinite(magnitude) || magnitude < 0.0) throw std::invalid_argument("magnitude must be >= 0");
  const Box box = SamplingBox(s);
  // 100 times the expected number of draws: reached only if the kept region is mis-modelled.
  const double acceptance = KeptFraction(s) * BoxVolume(s) / box.Volume();
  const double max_draws = 100.0 * static_cast<double>(trials) / acceptance + 1000.0;
  Rng rng(PointSeed(seed, f, point_index));
  PointResult r;
  r.magnitude = magnitude;
  double sum_sq = 0.0;
  while (r.trials < trials) {
    if (static_cast<double>(r.draws) >= max_draws)
      throw std::invalid_argument("too few beacons kept: the beacon box is almost out of view");
    ++r.draws;
    const Eigen::Vector3d P(rng.Uniform(box.lo.x(), box.hi.x()), rng.Uniform(box.lo.y(), box.hi.y()),
                            rng.Uniform(box.lo.z(), box.hi.z()));
    if (!KeepBeacon(s, P)) continue;
    const Eigen::Vector3d e = DrawError(rng, s.draw, magnitude);
    double u = 0.0, u_err = 0.0;
    if (!PerturbedU(s, f, P, Eigen::Vector3d::Zero(), &u) || !PerturbedU(s, f, P, e, &u_err)) continue;
    sum_sq += (u_err - u) * (u_err - u);
    ++r.trials;
  }
  r.mc_rms_px = std::sqrt(sum_sq / static_cast<double>(r.trials));
  return r;
}

FigureResult RunFigure(const AnalysisSetup& s, ErrorFigure f, double max_magnitude, int points,
                       std::int64_t trials, std::uint64_t seed, const PointProgress& progress) {
  if (points < 2) throw std::invalid_argument("points must be >= 2");
  if (!std::isfinite(max_magnitude) || !(max_magnitude > 0.0))
    throw std::invalid_argument("the largest error must be > 0");
  FigureResult out;
  out.figure = f;
  out.analytic_slope = AnalyticSlope(s, f);
  std::vector<double> xs, ys;
  for (int i = 0; i < points; ++i) {
    const double m = max_magnitude * i / (points - 1);
    PointResult p = RunPoint(s, f, m, trials, seed, i);
    p.analytic_rms_px = out.analytic_slope * m;
    out.points.push_back(p);
    xs.push_back(m);
    ys.push_back(p.mc_rms_px);
    if (progress) progress(i, points, p);
  }
  out.mc_slope = SlopeThroughOrigin(xs, ys);
  return out;
}

double SlopeThroughOrigin(const std::vector<double>& x, const std::vector<double>& y) {
  double sxy = 0.0, sxx = 0.0;
  for (std::size_t i = 0; i < x.size() && i < y.size(); ++i) {
    sxy += x[i] * y[i];
    sxx += x[i] * x[i];
  }
  return sxx > 0.0 ? sxy / sxx : 0.0;
}

double ToDisplayUnit(ErrorFigure f, double m) { return f == ErrorFigure::kCameraAttitude ? RadToDeg(m) : m * 1e3; }
double FromDisplayUnit(ErrorFigure f, double m) {
  return f == ErrorFigure::kCameraAttitude ? DegToRad(m) : m * 1e-3;
}
const char* DisplayUnit(ErrorFigure f) { return f == ErrorFigure::kCameraAttitude ? "deg" : "mm"; }

std::string FigureCsv(const FigureResult& r) {
  std::string csv = std::string("error_") + DisplayUnit(r.figure) + ",mc_rms_u_px,analytic_rms_u_px,trials\n";
  char line[160];
  for (const PointResult& p : r.points) {
    std::snprintf(line, sizeof line, "%.9g,%.9g,%.9g,%" PRId64 "\n", ToDisplayUnit(r.figure, p.magnitude),
                  p.mc_rms_px, p.analytic_rms_px, p.trials);
    csv += line;
  }
  return csv;
}

}  // namespace mfns::host
