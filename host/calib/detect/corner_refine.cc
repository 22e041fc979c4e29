#include "host/calib/detect/corner_refine.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace mfns::host {
namespace {

constexpr int kGaussNodes = 20;
constexpr double kFar = 8.5;  // standardised distance beyond which an edge's side is certain
constexpr double kMaxAbsRho = 0.95;  // edges closer than ~18 deg to parallel: not a corner
constexpr int kNumParams = 10;  // u, v, th1, th2, s, m, h, gx, gy, a
enum Param : int { kU = 0, kV, kTh1, kTh2, kS, kM, kH, kGx, kGy, kA };
constexpr double kMaxTap = 0.25;  // [a, 1 - 2a, a] stays a unimodal blur

// Gauss-Legendre nodes and weights on [-1, 1] (Newton on P_n from the Chebyshev guesses).
struct GaussLegendre {
  std::array<double, kGaussNodes> x{}, w{};
  GaussLegendre() {
    const int n = kGaussNodes;
    for (int i = 0; i < n; ++i) {
      double z = std::cos(std::numbers::pi * (i + 0.75) / (n + 0.5));
      double dp = 1.0;
      for (int it = 0; it < 100; ++it) {
        double p0 = 1.0, p1 = z;
        for (int k = 2; k <= n; ++k) {
          const double p2 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p0) / k;
          p0 = p1;
          p1 = p2;
        }
        dp = n * (z * p1 - p0) / (z * z - 1.0);
        const double dz = p1 / dp;
        z -= dz;
        if (std::abs(dz) < 1e-16) break;
      }
      x[static_cast<std::size_t>(i)] = z;
      w[static_cast<std::size_t>(i)] = 2.0 / ((1.0 - z * z) * dp * dp);
    }
  }
};

const GaussLegendre& Nodes() {
  static const GaussLegendre g;
  return g;
}

constexpr double kInvSqrt2 = 0.5 * std::numbers::sqrt2;
constexpr double kInvSqrt2Pi = kInvSqrt2 * std::numbers::inv_sqrtpi;
double NormalCdf(double x) { return 0.5 * std::erfc(-x * kInvSqrt2); }
double NormalPdf(double x) { return kInvSqrt2Pi * std::exp(-0.5 * x * x); }

// The rho-dependent part of Genz's formula, prepared once per correlation:
//   Phi2(h, k; rho) = Phi(h) Phi(k) + asin(rho) / (4 pi) sum_i w_i exp((sn_i h k - (h^2 + k^2) / 2) / (1 - sn_i^2)),
//   sn_i = sin(asin(rho) (x_i + 1) / 2).
class PreparedRho {
 public:
  explicit PreparedRho(double rho) : rho_(rho) {
    const GaussLegendre& g = Nodes();
    const double asr = std::asin(rho);
    scale_ = asr / (4.0 * std::numbers::pi);
    for (std::size_t i = 0; i < g.x.size(); ++i) {
      sn_[i] = std::sin(asr * (g.x[i] + 1.0) / 2.0);
      inv_[i] = 1.0 / (1.0 - sn_[i] * sn_[i]);
    }
    s_ = std::sqrt(1.0 - rho * rho);
  }

  double Cdf(double h, double k) const {
    const GaussLegendre& g = Nodes();
    const double hk = h * k, hs = 0.5 * (h * h + k * k);
    double sum = 0.0;
    for (std::size_t i = 0; i < g.x.size(); ++i) sum += g.w[i] * std::exp((sn_[i] * hk - hs) * inv_[i]);
    return NormalCdf(h) * NormalCdf(k) + scale_ * sum;
  }

  CornerProfile Corner(double mu1, double mu2) const {
    CornerProfile p;
    // Far from one edge its sign is certain (Phi(-8.5) < 1e-17): one edge's profile, or a constant.
    if (std::abs(mu1) > kFar || std::abs(mu2) > kFar) {
      const bool far1 = std::abs(mu1) > kFar, far2 = std::abs(mu2) > kFar;
      const double sg1 = mu1 > 0 ? 1.0 : -1.0, sg2 = mu2 > 0 ? 1.0 : -1.0;
      if (far1 && far2) {
        p.f = sg1 * sg2;
      } else if (far2) {
        p.f = sg2 * (2.0 * NormalCdf(mu1) - 1.0);
        p.df_dmu1 = sg2 * 2.0 * NormalPdf(mu1);
      } else {
        p.f = sg1 * (2.0 * NormalCdf(mu2) - 1.0);
        p.df_dmu2 = sg1 * 2.0 * NormalPdf(mu2);
      }
      return p;
    }
    const double c1 = NormalCdf(mu1), c2 = NormalCdf(mu2);
    p.f = 4.0 * Cdf(mu1, mu2) - 2.0 * c1 - 2.0 * c2 + 1.0;
    p.df_dmu1 = 2.0 * NormalPdf(mu1) * (2.0 * NormalCdf((mu2 - rho_ * mu1) / s_) - 1.0);
    p.df_dmu2 = 2.0 * NormalPdf(mu2) * (2.0 * NormalCdf((mu1 - rho_ * mu2) / s_) - 1.0);
    p.df_drho = 4.0 * std::exp(-(mu1 * mu1 - 2.0 * rho_ * mu1 * mu2 + mu2 * mu2) / (2.0 * s_ * s_)) /
                (2.0 * std::numbers::pi * s_);
    return p;
  }

 private:
  double rho_, scale_ = 0.0, s_ = 1.0;
  std::array<double, kGaussNodes> sn_{}, inv_{};
};

struct Pixel {
  double dx, dy;  // x - x0 (px)
  double value;   // image value
  double w;       // weight
  int cell;       // its grid cell (row-major, Window::nx per row)
};

// The pixels of the fit and the grid of pixel positions where the profile is evaluated: the
// pixels' bounding box plus one pixel on each side (the 3-tap kernel's reach).
struct Window {
  int nx = 0, ny = 0;          // grid size
  double dx0 = 0, dy0 = 0;     // position of grid cell (0, 0) relative to x0 (px)
  std::vector<Pixel> pixels;
  std::vector<char> needed;    // cells a pixel uses without the 3-tap kernel
};

using Vec = Eigen::Matrix<double, kNumParams, 1>;
using Mat = Eigen::Matrix<double, kNumParams, kNumParams>;

// Flat-topped window: 1 inside 0.6 r, a cosine taper to 0 at r.
double Taper(double rho_px, double r) {
  const double t = rho_px / r;
  if (t <= 0.6) return 1.0;
  if (t >= 1.0) return 0.0;
  return 0.5 * (1.0 + std::cos(std::numbers::pi * (t - 0.6) / 0.4));
}

// The pixel's area: F is averaged over n x n points at the centres of n x n equal sub-squares.
struct SubSamples {
  int n = 1, count = 1;
  std::array<double, 64> dx{}, dy{};
  explicit SubSamples(int per_axis) {
    n = std::clamp(per_axis, 1, 8);
    count = 0;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        dx[static_cast<std::size_t>(count)] = (i + 0.5) / n - 0.5;
        dy[static_cast<std::size_t>(count)] = (j + 0.5) / n - 0.5;
        ++count;
      }
  }
};

// F averaged over a pixel and its derivatives w.r.t. the geometric parameters.
struct PixelProfile {
  double f = 0, du = 0, dv = 0, dth1 = 0, dth2 = 0, ds = 0;
};

// Geometry of one parameter vector, shared by every pixel.
struct Geometry {
  double c1, s1, c2, s2, sin12;
  explicit Geometry(const Vec& p)
      : c1(std::cos(p[kTh1])), s1(std::sin(p[kTh1])), c2(std::cos(p[kTh2])), s2(std::sin(p[kTh2])),
        sin12(std::sin(p[kTh1] - p[kTh2])) {}
};

PixelProfile Profile(const Vec& p, const Geometry& G, const PreparedRho& pr, const SubSamples& sub, double cell_dx,
                     double cell_dy, bool derivatives) {
  PixelProfile out;
  const double s = p[kS];
  for (int n = 0; n < sub.count; ++n) {
    const double ex = cell_dx + sub.dx[static_cast<std::size_t>(n)] - p[kU];
    const double ey = cell_dy + sub.dy[static_cast<std::size_t>(n)] - p[kV];
    const double a1 = G.c1 * ex + G.s1 * ey, b1 = -G.s1 * ex + G.c1 * ey;
    const double a2 = G.c2 * ex + G.s2 * ey, b2 = -G.s2 * ex + G.c2 * ey;
    const double mu1 = a1 / s, mu2 = a2 / s;
    const CornerProfile f = pr.Corner(mu1, mu2);
    out.f += f.f;
    if (!derivatives || (f.df_dmu1 == 0.0 && f.df_dmu2 == 0.0 && f.df_drho == 0.0)) continue;
    // d d_i / d c = -n_i; d d_i / d th_i = t_i . (x - c) = b_i with t_i = (-sin th_i, cos th_i).
    out.du -= (f.df_dmu1 * G.c1 + f.df_dmu2 * G.c2) / s;
    out.dv -= (f.df_dmu1 * G.s1 + f.df_dmu2 * G.s2) / s;
    out.dth1 += f.df_dmu1 * b1 / s - f.df_drho * G.sin12;
    out.dth2 += f.df_dmu2 * b2 / s + f.df_drho * G.sin12;
    out.ds -= (f.df_dmu1 * mu1 + f.df_dmu2 * mu2) / s;
  }
  const double inv = 1.0 / sub.count;
  out.f *= inv;
  out.du *= inv;
  out.dv *= inv;
  out.dth1 *= inv;
  out.dth2 *= inv;
  out.ds *= inv;
  return out;
}

double Rho(const Vec& p) { return std::cos(p[kTh1] - p[kTh2]); }

// Adds c * q to *acc (value and derivatives).
void AddScaled(double c, const PixelProfile& q, PixelProfile* acc) {
  acc->f += c * q.f;
  acc->du += c * q.du;
  acc->dv += c * q.dv;
  acc->dth1 += c * q.dth1;
  acc->dth2 += c * q.dth2;
  acc->ds += c * q.ds;
}

// Weighted sum of squared residuals; accumulates the normal equations when H, g are given.
// With the 3-tap kernel, a pixel's profile is sum_kl w_k w_l F(cell + (k, l)), w = [a, 1 - 2a, a].
double Accumulate(const Vec& p, const Window& win, const SubSamples& sub, bool taps, Mat* H, Vec* g) {
  const PreparedRho pr(Rho(p));
  const Geometry G(p);
  const bool derivatives = H != nullptr;
  std::vector<PixelProfile> cells(win.needed.size());
  for (int iy = 0; iy < win.ny; ++iy)
    for (int ix = 0; ix < win.nx; ++ix) {
      const std::size_t c = static_cast<std::size_t>(iy * win.nx + ix);
      if (taps || win.needed[c]) cells[c] = Profile(p, G, pr, sub, win.dx0 + ix, win.dy0 + iy, derivatives);
    }
  const double a = taps ? p[kA] : 0.0;
  const std::array<double, 3> w{a, 1.0 - 2.0 * a, a}, dw{1.0, -2.0, 1.0};
  double cost = 0.0;
  Vec J;
  if (derivatives) {
    H->setZero();
    g->setZero();
  }
  for (const Pixel& px : win.pixels) {
    PixelProfile f;
    double df_da = 0.0;
    if (taps) {
      for (int l = -1; l <= 1; ++l)
        for (int k = -1; k <= 1; ++k) {
          const PixelProfile& q = cells[static_cast<std::size_t>(px.cell + l * win.nx + k)];
          const std::size_t ik = static_cast<std::size_t>(k + 1), il = static_cast<std::size_t>(l + 1);
          AddScaled(w[ik] * w[il], q, &f);
          df_da += (dw[ik] * w[il] + w[ik] * dw[il]) * q.f;
        }
    } else {
      f = cells[static_cast<std::size_t>(px.cell)];
    }
    const double L = 1.0 + p[kGx] * px.dx + p[kGy] * px.dy;
    const double B = p[kM] + p[kH] * f.f;
    const double r = L * B - px.value;
    cost += px.w * r * r;
    if (derivatives) {
      const double lh = L * p[kH];
      J[kU] = lh * f.du;
      J[kV] = lh * f.dv;
      J[kTh1] = lh * f.dth1;
      J[kTh2] = lh * f.dth2;
      J[kS] = lh * f.ds;
      J[kM] = L;
      J[kH] = L * f.f;
      J[kGx] = px.dx * B;
      J[kGy] = px.dy * B;
      J[kA] = lh * df_da;
      H->selfadjointView<Eigen::Upper>().rankUpdate(J, px.w);
      *g += px.w * r * J;
    }
  }
  if (derivatives) *H = H->selfadjointView<Eigen::Upper>();
  return cost;
}

double PixelValue(const cv::Mat& image, int x, int y) {
  return image.type() == CV_8UC1 ? static_cast<double>(image.at<unsigned char>(y, x))
                                 : static_cast<double>(image.at<unsigned short>(y, x));
}

Eigen::Vector2d Perp(const Eigen::Vector2d& e) { return Eigen::Vector2d(-e.y(), e.x()); }

}  // namespace

const char* ToString(CornerRefineStatus s) {
  switch (s) {
    case CornerRefineStatus::kRefined: return "refined";
    case CornerRefineStatus::kWindowTooSmall: return "window too small or cut by the image border";
    case CornerRefineStatus::kNotConverged: return "fit did not converge";
    case CornerRefineStatus::kMovedTooFar: return "fit moved the corner too far";
    case CornerRefineStatus::kBadFit: return "implausible fit (blur, contrast or edge angle)";
    case CornerRefineStatus::kCount: break;
  }
  return "unknown";
}

int CornerRefineStats::Kept() const {
  int n = 0;
  for (std::size_t i = 1; i < count.size(); ++i) n += count[i];
  return n;
}

double BivariateNormalCdf(double h, double k, double rho) {
  if (!(std::abs(rho) <= kMaxAbsRho)) throw std::invalid_argument("BivariateNormalCdf: |rho| must be <= 0.95");
  return PreparedRho(rho).Cdf(h, k);
}

CornerProfile BlurredCorner(double mu1, double mu2, double rho) {
  if (!(std::abs(rho) <= kMaxAbsRho)) throw std::invalid_argument("BlurredCorner: |rho| must be <= 0.95");
  return PreparedRho(rho).Corner(mu1, mu2);
}

CornerFit RefineCorner(const cv::Mat& image, const Eigen::Vector2d& uv0, const Eigen::Vector2d& edge1_px,
                       const Eigen::Vector2d& edge2_px, double radius_px, const CornerRefineOptions& o) {
  if (image.type() != CV_8UC1 && image.type() != CV_16UC1)
    throw std::invalid_argument("RefineCorner: image must be CV_8UC1 or CV_16UC1");
  CornerFit fit;
  fit.uv = uv0;
  // Near the image border the window shrinks to stay inside.
  const double r = std::min({radius_px, uv0.x(), uv0.y(), image.cols - 1.0 - uv0.x(), image.rows - 1.0 - uv0.y()});
  fit.radius_px = r;
  if (!(r >= o.min_radius_px) || !uv0.allFinite()) {
    fit.status = CornerRefineStatus::kWindowTooSmall;
    return fit;
  }
  // The window's pixels (fixed during the fit: the model, not the window, follows the corner).
  Window win;
  const int x_lo = static_cast<int>(std::ceil(uv0.x() - r)), x_hi = static_cast<int>(std::floor(uv0.x() + r));
  const int y_lo = static_cast<int>(std::ceil(uv0.y() - r)), y_hi = static_cast<int>(std::floor(uv0.y() + r));
  win.nx = x_hi - x_lo + 3;
  win.ny = y_hi - y_lo + 3;
  win.dx0 = (x_lo - 1) - uv0.x();
  win.dy0 = (y_lo - 1) - uv0.y();
  win.needed.assign(static_cast<std::size_t>(win.nx * win.ny), 0);
  win.pixels.reserve(static_cast<std::size_t>((x_hi - x_lo + 1) * (y_hi - y_lo + 1)));
  for (int y = y_lo; y <= y_hi; ++y)
    for (int x = x_lo; x <= x_hi; ++x) {
      const double dx = x - uv0.x(), dy = y - uv0.y();
      const double w = Taper(std::hypot(dx, dy), r);
      if (!(w > 0.0)) continue;
      const int cell = (y - y_lo + 1) * win.nx + (x - x_lo + 1);
      win.pixels.push_back({dx, dy, PixelValue(image, x, y), w, cell});
      win.needed[static_cast<std::size_t>(cell)] = 1;
    }
  const std::vector<Pixel>& pixels = win.pixels;

  // Start: edges from the grid, blur 1 px, then the levels by linear least squares.
  Vec p = Vec::Zero();
  const Eigen::Vector2d n1 = Perp(edge1_px).normalized(), n2 = Perp(edge2_px).normalized();
  p[kTh1] = std::atan2(n1.y(), n1.x());
  p[kTh2] = std::atan2(n2.y(), n2.x());
  p[kS] = 1.0;
  if (!(std::abs(Rho(p)) < kMaxAbsRho)) {
    fit.status = CornerRefineStatus::kBadFit;
    return fit;
  }
  {
    const PreparedRho pr(Rho(p));
    Eigen::Matrix2d A = Eigen::Matrix2d::Zero();
    Eigen::Vector2d b = Eigen::Vector2d::Zero();
    for (const Pixel& px : pixels) {
      const double c1 = std::cos(p[kTh1]), s1 = std::sin(p[kTh1]), c2 = std::cos(p[kTh2]), s2 = std::sin(p[kTh2]);
      const double f = pr.Corner((c1 * px.dx + s1 * px.dy) / p[kS], (c2 * px.dx + s2 * px.dy) / p[kS]).f;
      const Eigen::Vector2d a(1.0, f);
      A += px.w * a * a.transpose();
      b += px.w * px.value * a;
    }
    const Eigen::Vector2d mh = A.ldlt().solve(b);
    p[kM] = mh[0];
    p[kH] = mh[1];
  }

  // Levenberg-Marquardt (Marquardt's diagonal scaling); free parameters per the options.
  const SubSamples sub(o.pixel_subsamples);
  // The pixel's area blurs at least as a box of 1 px (variance 1/12 per axis); the sub-samples
  // model part of it (variance (1 - 1/n^2) / 12), s must supply the rest. Below that bound a
  // sharp edge along the pixel grid leaves s and the position undetermined.
  const double s_min = std::sqrt((1.0 / 12.0) / (sub.n * sub.n));
  std::array<bool, kNumParams> free{};
  free.fill(true);
  free[kGx] = free[kGy] = o.fit_gradient;
  free[kA] = o.fit_pixel_kernel;
  Mat H;
  Vec g;
  double cost = Accumulate(p, win, sub, o.fit_pixel_kernel, &H, &g);
  double lambda = 1e-3;
  bool converged = false;
  int it = 0;
  // Corner positions of the last accepted steps: the blur's shape parameters can creep along a
  // shallow valley for many steps after the corner has settled.
  constexpr int kSettle = 8;
  std::array<Eigen::Vector2d, kSettle> recent{};
  int accepted_steps = 0;
  for (; it < o.max_iterations && !converged; ++it) {
    bool accepted = false;
    for (int tries = 0; tries < 12 && !accepted; ++tries) {
      Mat A = H;
      Vec rhs = -g;
      for (int i = 0; i < kNumParams; ++i) {
        if (!free[static_cast<std::size_t>(i)]) {
          A.row(i).setZero();
          A.col(i).setZero();
          A(i, i) = 1.0;
          rhs[i] = 0.0;
        } else {
          A(i, i) += lambda * std::max(H(i, i), 1e-12);
        }
      }
      const Eigen::LDLT<Mat> ldlt(A);
      if (ldlt.info() != Eigen::Success) break;
      const Vec dp = ldlt.solve(rhs);
      Vec q = p + dp;
      q[kS] = std::max(q[kS], s_min);
      q[kA] = std::clamp(q[kA], 0.0, kMaxTap);
      if (!dp.allFinite() || !(std::abs(Rho(q)) < kMaxAbsRho)) {
        lambda *= 10.0;
        continue;
      }
      const double new_cost = Accumulate(q, win, sub, o.fit_pixel_kernel, nullptr, nullptr);
      if (new_cost <= cost) {
        accepted = true;
        const double decrease = cost - new_cost;
        p = q;
        cost = Accumulate(p, win, sub, o.fit_pixel_kernel, &H, &g);
        lambda = std::max(lambda / 10.0, 1e-9);
        // Converged when the corner and the edges have stopped moving.
        converged = std::hypot(dp[kU], dp[kV]) < 1e-6 && std::abs(dp[kTh1]) + std::abs(dp[kTh2]) < 1e-7;
        converged = converged || decrease <= 1e-12 * cost;
        const Eigen::Vector2d uv_now(p[kU], p[kV]);
        Eigen::Vector2d& slot = recent[static_cast<std::size_t>(accepted_steps % kSettle)];
        converged = converged || (accepted_steps >= kSettle && (uv_now - slot).norm() < 1e-4);
        slot = uv_now;
        ++accepted_steps;
      } else {
        lambda *= 10.0;
      }
    }
    // No decrease possible even with a large damping: at the minimum to rounding.
    if (!accepted) {
      converged = lambda > 1e6 && g.norm() <= 1e-6 * (1.0 + cost);
      if (!converged) break;
    }
  }
  fit.iterations = it;
  double wsum = 0.0;
  for (const Pixel& px : pixels) wsum += px.w;
  fit.rms_dn = std::sqrt(cost / std::max(wsum, 1e-12));
  fit.blur_px = p[kS];
  fit.kernel_a = p[kA];
  const Eigen::Vector2d uv = uv0 + Eigen::Vector2d(p[kU], p[kV]);
  if (!converged || !uv.allFinite()) {
    fit.status = CornerRefineStatus::kNotConverged;
  } else if ((uv - uv0).norm() > o.max_shift_px) {
    fit.status = CornerRefineStatus::kMovedTooFar;
  } else if (!(p[kS] < 6.0) || !(std::abs(p[kH]) > 0.04 * std::abs(p[kM])) ||
             !(std::abs(Rho(p)) < kMaxAbsRho)) {
    fit.status = CornerRefineStatus::kBadFit;
  } else {
    fit.status = CornerRefineStatus::kRefined;
    fit.uv = uv;
  }
  return fit;
}

std::vector<CornerFit> RefineCheckerboardCorners(const cv::Mat& image, int rows, int cols,
                                                 const std::vector<Eigen::Vector2d>& uv, const CornerRefineOptions& o,
                                                 CornerRefineStats* stats) {
  if (rows < 2 || cols < 2 || uv.size() != static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols))
    throw std::invalid_argument("RefineCheckerboardCorners: need rows * cols >= 4 corners in grid order");
  if (image.type() != CV_8UC1 && image.type() != CV_16UC1)
    throw std::invalid_argument("RefineCheckerboardCorners: image must be CV_8UC1 or CV_16UC1");
  auto at = [&](int r, int c) -> const Eigen::Vector2d& { return uv[static_cast<std::size_t>(r * cols + c)]; };
  std::vector<CornerFit> out;
  out.reserve(uv.size());
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      const Eigen::Vector2d& p = at(r, c);
      // Vectors to the row (a) and column (b) neighbours on each side; a missing neighbour
      // (outer ring) is the other side's mirrored: the board's outer squares are as large.
      const Eigen::Vector2d a_plus = c + 1 < cols ? Eigen::Vector2d(at(r, c + 1) - p) : Eigen::Vector2d(p - at(r, c - 1));
      const Eigen::Vector2d a_minus = c > 0 ? Eigen::Vector2d(at(r, c - 1) - p) : Eigen::Vector2d(-a_plus);
      const Eigen::Vector2d b_plus = r + 1 < rows ? Eigen::Vector2d(at(r + 1, c) - p) : Eigen::Vector2d(p - at(r - 1, c));
      const Eigen::Vector2d b_minus = r > 0 ? Eigen::Vector2d(at(r - 1, c) - p) : Eigen::Vector2d(-b_plus);
      // Nearest side of the four adjacent squares not through the corner: for the square
      // spanned by a and b, |a x b| / |b| and |a x b| / |a|.
      double height = 1e9;
      for (const Eigen::Vector2d* a : {&a_plus, &a_minus})
        for (const Eigen::Vector2d* b : {&b_plus, &b_minus}) {
          const double area = std::abs(a->x() * b->y() - a->y() * b->x());
          height = std::min({height, area / std::max(a->norm(), 1e-9), area / std::max(b->norm(), 1e-9)});
        }
      const double radius = std::min(o.max_radius_px, o.window_fraction * height);
      CornerFit f = RefineCorner(image, p, a_plus - a_minus, b_plus - b_minus, radius, o);
      if (stats != nullptr) ++stats->count[static_cast<std::size_t>(f.status)];
      out.push_back(f);
    }
  return out;
}

}  // namespace mfns::host
