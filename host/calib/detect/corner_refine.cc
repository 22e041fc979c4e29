#include "host/calib/detect/corner_refine.h"

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace mfns::host {
namespace {

// Standardised distance beyond which an edge's side is taken as certain: Phi(-6) = 1e-9 of the
// contrast (8.5 before: 30 % more of the window in the edge profiles, for nothing measurable).
constexpr double kFar = 6.0;
constexpr double kMaxAbsRho = 0.95;  // edges closer than ~18 deg to parallel: not a corner
constexpr int kNumParams = 10;  // u, v, th1, th2, s, m, h, gx, gy, a
enum Param : int { kU = 0, kV, kTh1, kTh2, kS, kM, kH, kGx, kGy, kA };
constexpr double kMaxTap = 0.25;  // [a, 1 - 2a, a] stays a unimodal blur
// The edge blur's lower bound. Where two edges meet, n x n sub-samples with s_eff^2 = s^2 +
// 1 / (12 n^2) stand for the pixel's area (the one-edge cells average it exactly): with 3 x 3 at
// s = 0.1 they differ from the exact area by up to ~0.5 % of the contrast in those few cells;
// 5 x 5 (0.06 %) gave the same corners at 1.6x the cost, and a bound of 0.05 the same corners in
// more iterations (small-tags, paper-calibration AprilGrid and checkerboard, session 26).
constexpr double kMinBlurPx = 0.1;

// Gauss-Legendre nodes and weights on [-1, 1] (Newton on P_n from the Chebyshev guesses).
constexpr int kMaxGaussNodes = 20;
struct GaussLegendre {
  int n = 0;
  std::array<double, kMaxGaussNodes> x{}, w{};
  explicit GaussLegendre(int nodes) : n(nodes) {
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

// Genz (2004, "Numerical computation of rectangular bivariate and trivariate normal and t
// probabilities"): the integrand over asin(rho) is smooth enough for double precision with 6
// nodes when |rho| < 0.3, 12 when |rho| < 0.75, 20 above (tested against a quadrature).
const GaussLegendre& Nodes(double abs_rho) {
  static const GaussLegendre g6(6), g12(12), g20(20);
  return abs_rho < 0.3 ? g6 : (abs_rho < 0.75 ? g12 : g20);
}

constexpr double kInvSqrt2 = 0.5 * std::numbers::sqrt2;
constexpr double kInvSqrt2Pi = kInvSqrt2 * std::numbers::inv_sqrtpi;

// Phi(x) and phi(x) from one exp: Phi(x) = erfc(-x / sqrt 2) / 2 with erfc(t) = erfcx(t) exp(-t^2),
// where erfcx, the scaled complementary error function, is smooth and slowly varying: a Taylor
// polynomial of degree 8 about the centre of each 1/16-wide interval of [0, 4.5] (|x| < 6.36,
// where the fit evaluates edge profiles), from erfcx' = 2 t erfcx - 2 / sqrt(pi) and std::erfc
// at the centres (error ~1e-16). std::erfc alone costs two exps in its tail; this halves the
// cost of the edge profiles, the fit's largest part. Beyond 4.5: std::erfc.
class Erfcx {
 public:
  static constexpr int kDeg = 8, kIntervals = 72;
  static constexpr double kWidth = 1.0 / 16.0, kMax = kIntervals * kWidth;
  Erfcx() {
    for (int i = 0; i < kIntervals; ++i) {
      const double t0 = (i + 0.5) * kWidth;
      std::array<double, kDeg + 1>& a = c_[static_cast<std::size_t>(i)];
      a[0] = std::erfc(t0) * std::exp(t0 * t0);
      a[1] = 2.0 * t0 * a[0] - 2.0 * std::numbers::inv_sqrtpi;
      for (std::size_t k = 1; k < static_cast<std::size_t>(kDeg); ++k)
        a[k + 1] = 2.0 * (t0 * a[k] + a[k - 1]) / static_cast<double>(k + 1);
    }
  }
  // 0 <= t < kMax.
  double operator()(double t) const {
    const int i = std::min(static_cast<int>(t * (1.0 / kWidth)), kIntervals - 1);
    const double h = t - (i + 0.5) * kWidth;
    const std::array<double, kDeg + 1>& a = c_[static_cast<std::size_t>(i)];
    double v = a[kDeg];
    for (int k = kDeg - 1; k >= 0; --k) v = v * h + a[static_cast<std::size_t>(k)];
    return v;
  }

 private:
  std::array<std::array<double, kDeg + 1>, kIntervals> c_{};
};

const Erfcx& ErfcxTable() {
  static const Erfcx table;
  return table;
}

struct NormalCdfPdf {
  double cdf, pdf;
};
// erfcx: ErfcxTable(), passed in to keep the static's guard out of the inner loops.
NormalCdfPdf NormalBoth(double x, const Erfcx& erfcx) {
  const double t = std::abs(x) * kInvSqrt2, e = std::exp(-0.5 * x * x);
  if (!(t < Erfcx::kMax)) return {0.5 * std::erfc(-x * kInvSqrt2), kInvSqrt2Pi * e};
  const double half_tail = 0.5 * erfcx(t) * e;  // Phi(-|x|)
  return {x < 0.0 ? half_tail : 1.0 - half_tail, kInvSqrt2Pi * e};
}


// The rho-dependent part of Genz's formula, prepared once per correlation:
//   Phi2(h, k; rho) = Phi(h) Phi(k) + asin(rho) / (4 pi) sum_i w_i exp((sn_i h k - (h^2 + k^2) / 2) / (1 - sn_i^2)),
//   sn_i = sin(asin(rho) (x_i + 1) / 2).
class PreparedRho {
 public:
  explicit PreparedRho(double rho) : rho_(rho), g_(&Nodes(std::abs(rho))) {
    const GaussLegendre& g = *g_;
    const double asr = std::asin(rho);
    scale_ = asr / (4.0 * std::numbers::pi);
    for (std::size_t i = 0; i < static_cast<std::size_t>(g.n); ++i) {
      sn_[i] = std::sin(asr * (g.x[i] + 1.0) / 2.0);
      inv_[i] = 1.0 / (1.0 - sn_[i] * sn_[i]);
    }
    s_ = std::sqrt(1.0 - rho * rho);
  }

  double Cdf(double h, double k) const { return CdfGiven(h, k, NormalBoth(h, *erfcx_).cdf, NormalBoth(k, *erfcx_).cdf); }

  CornerProfile Corner(double mu1, double mu2) const {
    CornerProfile p;
    // Far from one edge its sign is certain (Phi(-6) = 1e-9): one edge's profile, or a constant.
    if (std::abs(mu1) > kFar || std::abs(mu2) > kFar) {
      const bool far1 = std::abs(mu1) > kFar, far2 = std::abs(mu2) > kFar;
      const double sg1 = mu1 > 0 ? 1.0 : -1.0, sg2 = mu2 > 0 ? 1.0 : -1.0;
      if (far1 && far2) {
        p.f = sg1 * sg2;
      } else if (far2) {
        const NormalCdfPdf n1 = NormalBoth(mu1, *erfcx_);
        p.f = sg2 * (2.0 * n1.cdf - 1.0);
        p.df_dmu1 = sg2 * 2.0 * n1.pdf;
      } else {
        const NormalCdfPdf n2 = NormalBoth(mu2, *erfcx_);
        p.f = sg1 * (2.0 * n2.cdf - 1.0);
        p.df_dmu2 = sg1 * 2.0 * n2.pdf;
      }
      return p;
    }
    const NormalCdfPdf n1 = NormalBoth(mu1, *erfcx_), n2 = NormalBoth(mu2, *erfcx_);
    p.f = 4.0 * CdfGiven(mu1, mu2, n1.cdf, n2.cdf) - 2.0 * n1.cdf - 2.0 * n2.cdf + 1.0;
    p.df_dmu1 = 2.0 * n1.pdf * (2.0 * NormalBoth((mu2 - rho_ * mu1) / s_, *erfcx_).cdf - 1.0);
    p.df_dmu2 = 2.0 * n2.pdf * (2.0 * NormalBoth((mu1 - rho_ * mu2) / s_, *erfcx_).cdf - 1.0);
    p.df_drho = 4.0 * std::exp(-(mu1 * mu1 - 2.0 * rho_ * mu1 * mu2 + mu2 * mu2) / (2.0 * s_ * s_)) /
                (2.0 * std::numbers::pi * s_);
    return p;
  }

  // The L-corner's P_L = 2 Phi2(-mu1, -mu2) - 1 and its derivatives, from the same pieces as
  // Corner: dP_L/dmu1 = -2 phi(mu1) Phi(-(mu2 - rho mu1) / s), dP_L/drho = 2 phi2(mu1, mu2).
  CornerProfile LCorner(double mu1, double mu2) const {
    CornerProfile p;
    const bool far1 = std::abs(mu1) > kFar, far2 = std::abs(mu2) > kFar;
    if (far1 || far2) {
      if ((far1 && mu1 > 0) || (far2 && mu2 > 0) || (far1 && far2)) {  // outside, or deep inside
        p.f = mu1 < 0 && mu2 < 0 ? 1.0 : -1.0;
      } else if (far2) {  // inside edge 2's half-plane: edge 1's profile
        const NormalCdfPdf n1 = NormalBoth(mu1, *erfcx_);
        p.f = 1.0 - 2.0 * n1.cdf;
        p.df_dmu1 = -2.0 * n1.pdf;
      } else {
        const NormalCdfPdf n2 = NormalBoth(mu2, *erfcx_);
        p.f = 1.0 - 2.0 * n2.cdf;
        p.df_dmu2 = -2.0 * n2.pdf;
      }
      return p;
    }
    const NormalCdfPdf n1 = NormalBoth(mu1, *erfcx_), n2 = NormalBoth(mu2, *erfcx_);
    p.f = 2.0 * (1.0 - n1.cdf - n2.cdf + CdfGiven(mu1, mu2, n1.cdf, n2.cdf)) - 1.0;
    p.df_dmu1 = -2.0 * n1.pdf * NormalBoth((rho_ * mu1 - mu2) / s_, *erfcx_).cdf;
    p.df_dmu2 = -2.0 * n2.pdf * NormalBoth((rho_ * mu2 - mu1) / s_, *erfcx_).cdf;
    p.df_drho = 2.0 * std::exp(-(mu1 * mu1 - 2.0 * rho_ * mu1 * mu2 + mu2 * mu2) / (2.0 * s_ * s_)) /
                (2.0 * std::numbers::pi * s_);
    return p;
  }

 private:
  // Phi2(h, k) given Phi(h) and Phi(k).
  double CdfGiven(double h, double k, double cdf_h, double cdf_k) const {
    const GaussLegendre& g = *g_;
    const double hk = h * k, hs = 0.5 * (h * h + k * k);
    double sum = 0.0;
    for (std::size_t i = 0; i < static_cast<std::size_t>(g.n); ++i) sum += g.w[i] * std::exp((sn_[i] * hk - hs) * inv_[i]);
    return cdf_h * cdf_k + scale_ * sum;
  }

  double rho_;
  const GaussLegendre* g_;
  const Erfcx* erfcx_ = &ErfcxTable();
  double scale_ = 0.0, s_ = 1.0;
  std::array<double, kMaxGaussNodes> sn_{}, inv_{};
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
  int x_lo = 0, x_hi = -1, y_lo = 0, y_hi = -1;  // the image's pixel box the pixels come from
  int nx = 0, ny = 0;          // grid size
  double dx0 = 0, dy0 = 0;     // position of grid cell (0, 0) relative to x0 (px)
  std::vector<Pixel> pixels;
  std::vector<char> needed;    // cells a pixel uses without the 3-tap kernel
  std::vector<char> reached;   // cells a pixel uses with it (its 3 x 3 neighbourhood)
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

// Where two edges meet, the pixel's area: F is averaged over n x n points at the centres of n x n
// equal sub-squares (with their variance added to s, Geometry).
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
// A cell near one edge only is the exact pixel-area average of that edge's profile with blur s
// (BoxAveragedEdge); a cell near both edges averages n x n sub-samples, each the centre of a
// sub-square of variance 1 / (12 n^2) per axis, carried as extra blur: s_eff^2 = s^2 + 1 / (12 n^2).
struct Geometry {
  double c1, s1, c2, s2, sin12;
  double s;                 // the edge blur of one-edge cells
  double inv_s_eff;         // 1 / s_eff of the sub-sampled cells
  double ds_eff_ds;         // d s_eff / d s
  const Erfcx* erfcx = &ErfcxTable();
  Geometry(const Vec& p, const SubSamples& sub)
      : c1(std::cos(p[kTh1])), s1(std::sin(p[kTh1])), c2(std::cos(p[kTh2])), s2(std::sin(p[kTh2])),
        sin12(std::sin(p[kTh1] - p[kTh2])), s(p[kS]) {
    const double s_eff = std::sqrt(p[kS] * p[kS] + 1.0 / (12.0 * sub.n * sub.n));
    inv_s_eff = 1.0 / s_eff;
    ds_eff_ds = p[kS] / s_eff;
  }
};

// The unit pixel's average of Phi((d + cos(theta) x + sin(theta) y) / sigma) over x, y in
// [-1/2, 1/2] and its derivatives in d, sigma and theta (d held), in closed form: with
// alpha = |cos|, beta = |sin|, z_ij = (d + i alpha / 2 + j beta / 2) / sigma,
//   E = sigma^2 / (alpha beta) sum_ij i j Psi2(z_ij),  Psi2 = ((z^2 + 1) Phi + z phi) / 2,
// Psi2' = Psi1 = z Phi + phi, Psi1' = Phi; dE/dsigma = sigma / (alpha beta) sum i j Phi(z_ij).
// An edge within 1e-4 rad of the pixel grid: the limit beta -> 0 (a 1-D box).
// Phi and phi, exactly 1 or 0 and 0 beyond |z| = 8.5 (Phi(-8.5) = 1e-17; in Psi1 and Psi2 the
// neglected terms are below 1e-15 of the values that matter).
NormalCdfPdf TailNormal(double z, const Erfcx& erfcx) {
  if (z > 8.5) return {1.0, 0.0};
  if (z < -8.5) return {0.0, 0.0};
  return NormalBoth(z, erfcx);
}

// The terms of one pixel corner z_ij in the sums below.
struct EdgeCorner {
  double cdf, psi1, psi2;
};
EdgeCorner CornerTerms(double z, const Erfcx& erfcx) {
  const NormalCdfPdf n = TailNormal(z, erfcx);
  return {n.cdf, z * n.cdf + n.pdf, 0.5 * ((z * z + 1.0) * n.cdf + z * n.pdf)};
}

// d alpha / d theta and d beta / d theta into d E / d theta (d held):
// d|cos|/dtheta = -sign(cos) sin, d|sin|/dtheta = sign(sin) cos.
double ThetaDerivative(bool swap, double c, double sn, double e_alpha, double e_beta) {
  const double dabs_c = c >= 0.0 ? -sn : sn, dabs_s = sn >= 0.0 ? c : -c;
  return swap ? e_alpha * dabs_s + e_beta * dabs_c : e_alpha * dabs_c + e_beta * dabs_s;
}

// The sums over the pixel's corners, from the corners' terms v[2 xs + ys] at the pixel offsets
// (x, y) = ((2 xs - 1) / 2, (2 ys - 1) / 2), i.e. at z = (d + c x + sn y) / sigma: corner (x, y)
// is z_ij with i = sign(c) 2x, j = sign(sn) 2y (the roles swapped when alpha = |sn|). Needs
// beta >= 1e-4 (BoxAveragedEdge).
PixelEdge CombineCorners(const std::array<EdgeCorner, 4>& v, double c, double sn, double sigma) {
  const bool swap = std::abs(sn) > std::abs(c);  // alpha >= beta
  const double alpha = swap ? std::abs(sn) : std::abs(c), beta = swap ? std::abs(c) : std::abs(sn);
  double p2 = 0, p1 = 0, p0 = 0, qx = 0, qy = 0;  // sums weighted by 4xy, 4xy, 4xy, 2x, 2y
  for (int xs = 0; xs < 2; ++xs)
    for (int ys = 0; ys < 2; ++ys) {
      const EdgeCorner& t = v[static_cast<std::size_t>(2 * xs + ys)];
      const double x = 2.0 * xs - 1.0, y = 2.0 * ys - 1.0;
      p2 += x * y * t.psi2;
      p1 += x * y * t.psi1;
      p0 += x * y * t.cdf;
      qx += x * t.psi1;
      qy += y * t.psi1;
    }
  const double sc = c >= 0.0 ? 1.0 : -1.0, ss = sn >= 0.0 ? 1.0 : -1.0;
  const double k = sigma / (alpha * beta), kij = k * sc * ss;  // i j = sign(c) sign(sn) 4xy
  PixelEdge b;
  b.value = kij * sigma * p2;
  b.d_d = kij * p1;
  b.d_sigma = kij * p0;
  const double s1_i = swap ? sc * qx : ss * qy, s1_j = swap ? ss * qy : sc * qx;  // sum j Psi1, sum i Psi1
  const double e_alpha = -b.value / alpha + 0.5 * k * s1_i;
  const double e_beta = -b.value / beta + 0.5 * k * s1_j;
  b.d_theta = ThetaDerivative(swap, c, sn, e_alpha, e_beta);
  return b;
}

// Whether the edge's normal (c, sn) is far enough from the pixel grid for CombineCorners.
bool OffGrid(double c, double sn) { return std::min(std::abs(c), std::abs(sn)) >= 1e-4; }

PixelEdge BoxAveragedEdge(double d, double c, double sn, double sigma, const Erfcx& erfcx) {
  if (OffGrid(c, sn)) {
    std::array<EdgeCorner, 4> v;
    for (int xs = 0; xs < 2; ++xs)
      for (int ys = 0; ys < 2; ++ys)
        v[static_cast<std::size_t>(2 * xs + ys)] = CornerTerms((d + 0.5 * c * (2 * xs - 1) + 0.5 * sn * (2 * ys - 1)) / sigma, erfcx);
    return CombineCorners(v, c, sn, sigma);
  }
  const bool swap = std::abs(sn) > std::abs(c);
  const double alpha = swap ? std::abs(sn) : std::abs(c);
  const double zp = (d + 0.5 * alpha) / sigma, zm = (d - 0.5 * alpha) / sigma;
  const NormalCdfPdf np = TailNormal(zp, erfcx), nm = TailNormal(zm, erfcx);
  const double psi_p = zp * np.cdf + np.pdf, psi_m = zm * nm.cdf + nm.pdf;
  PixelEdge b;
  b.value = sigma / alpha * (psi_p - psi_m);
  b.d_d = (np.cdf - nm.cdf) / alpha;
  b.d_sigma = (np.pdf - nm.pdf) / alpha;
  const double e_alpha = -b.value / alpha + (np.cdf + nm.cdf) / (2.0 * alpha);
  b.d_theta = ThetaDerivative(swap, c, sn, e_alpha, 0.0);
  return b;
}

// The pixel-corner terms of one evaluation, per edge and vertex of the cell grid, each computed
// once: neighbouring one-edge pixels share their corners (about 1.2 corners per pixel along an
// edge's strip instead of 4, each a normal CDF and an exp).
class CornerCache {
 public:
  // A new evaluation at p over win's grid: vertex (vx, vy) sits at cell (vx, vy)'s centre - 1/2.
  void Start(const Window& win, const Vec& p) {
    nx1_ = win.nx + 1;
    const std::size_t n = static_cast<std::size_t>(nx1_) * static_cast<std::size_t>(win.ny + 1);
    for (std::size_t e = 0; e < 2; ++e) {
      if (stamp_[e].size() != n) {
        stamp_[e].assign(n, 0);
        terms_[e].resize(n);
      }
    }
    ++generation_;
    x0_ = win.dx0 - 0.5 - p[kU];
    y0_ = win.dy0 - 0.5 - p[kV];
  }
  // Cell (ix, iy)'s pixel average of edge e (0: edge 1) with normal (c, sn), blur sigma.
  PixelEdge Edge(std::size_t e, int ix, int iy, double c, double sn, double sigma, const Erfcx& erfcx) {
    std::array<EdgeCorner, 4> v;
    for (int xs = 0; xs < 2; ++xs)
      for (int ys = 0; ys < 2; ++ys) v[static_cast<std::size_t>(2 * xs + ys)] = Vertex(e, ix + xs, iy + ys, c, sn, sigma, erfcx);
    return CombineCorners(v, c, sn, sigma);
  }

 private:
  const EdgeCorner& Vertex(std::size_t e, int vx, int vy, double c, double sn, double sigma, const Erfcx& erfcx) {
    const std::size_t i = static_cast<std::size_t>(vy * nx1_ + vx);
    EdgeCorner& t = terms_[e][i];
    if (stamp_[e][i] != generation_) {
      stamp_[e][i] = generation_;
      t = CornerTerms((c * (x0_ + vx) + sn * (y0_ + vy)) / sigma, erfcx);
    }
    return t;
  }
  int nx1_ = 0;
  unsigned generation_ = 0;
  double x0_ = 0, y0_ = 0;
  std::array<std::vector<EdgeCorner>, 2> terms_;
  std::array<std::vector<unsigned>, 2> stamp_;
};

// A cell of the grid and the evaluation's corner cache.
struct CellAt {
  CornerCache* cache;
  int ix, iy;
};

// The ideal corner's value far from both edges: +1 on the quadrants the shape marks, else -1.
double FarSign(CornerShape shape, double d1, double d2) {
  if (shape == CornerShape::kX) return (d1 > 0) == (d2 > 0) ? 1.0 : -1.0;
  return d1 < 0 && d2 < 0 ? 1.0 : -1.0;
}

// The shape's blurred profile.
CornerProfile ShapeProfile(CornerShape shape, const PreparedRho& pr, double mu1, double mu2) {
  return shape == CornerShape::kX ? pr.Corner(mu1, mu2) : pr.LCorner(mu1, mu2);
}

enum CellKind : char { kFarBoth = 0, kNear1, kNear2, kNearBoth };

// A cell with its whole area far from one edge (edge 2 when far2, else edge 1): the other
// edge's profile averaged exactly over the pixel, P = A + B Phi(d / s), or a constant (false).
bool OneEdgeProfile(const Geometry& G, CornerShape shape, bool far2, double ex, double ey, double d1, double d2,
                    const CellAt& cell, PixelProfile* out) {
  const double d_far = far2 ? d2 : d1, d_near = far2 ? d1 : d2;
  const double sg = d_far > 0.0 ? 1.0 : -1.0;
  double A = 0.0, B = 0.0;
  if (shape == CornerShape::kX) {  // sg (2 Phi(mu) - 1)
    A = -sg;
    B = 2.0 * sg;
  } else if (d_far > 0.0) {  // outside the L's dark quadrant whatever the near edge says
    out->f = -1.0;
    return false;
  } else {  // 1 - 2 Phi(mu)
    A = 1.0;
    B = -2.0;
  }
  const double c = far2 ? G.c1 : G.c2, sn = far2 ? G.s1 : G.s2;
  // The whole pixel beyond 8.5 s of the near edge too: a constant (TailNormal's cut).
  if (std::abs(d_near) - 0.5 * (std::abs(c) + std::abs(sn)) > 8.5 * G.s) {
    out->f = A + B * (d_near > 0.0 ? 1.0 : 0.0);
    return false;
  }
  const PixelEdge b = OffGrid(c, sn) ? cell.cache->Edge(far2 ? 0u : 1u, cell.ix, cell.iy, c, sn, G.s, *G.erfcx)
                                     : BoxAveragedEdge(d_near, c, sn, G.s, *G.erfcx);
  const double bt = -sn * ex + c * ey;  // d d_near / d theta at the cell centre
  out->f = A + B * b.value;
  out->du = -B * b.d_d * c;
  out->dv = -B * b.d_d * sn;
  const double dth = B * (b.d_d * bt + b.d_theta);
  out->dth1 = far2 ? dth : 0.0;
  out->dth2 = far2 ? 0.0 : dth;
  out->ds = B * b.d_sigma;
  return true;
}

// The cell's profile; false (and F = +-1, no derivatives) when the whole pixel is far from both
// edges, as most of the window is.
// kind: the cell's model (CellKind), fixed while the geometry stays near where it was chosen,
// so that the cost is a smooth function of the parameters between re-classifications.
bool Profile(const Vec& p, const Geometry& G, const PreparedRho& pr, const SubSamples& sub, CornerShape shape,
             double cell_dx, double cell_dy, char kind, const CellAt& cell, PixelProfile* out_profile) {
  PixelProfile& out = *out_profile;
  out = PixelProfile{};
  const double ex_c = cell_dx - p[kU], ey_c = cell_dy - p[kV];
  const double d1c = G.c1 * ex_c + G.s1 * ey_c, d2c = G.c2 * ex_c + G.s2 * ey_c;
  if (kind == kFarBoth) {
    out.f = FarSign(shape, d1c, d2c);
    return false;
  }
  if (kind != kNearBoth) return OneEdgeProfile(G, shape, kind == kNear1, ex_c, ey_c, d1c, d2c, cell, out_profile);
  for (int n = 0; n < sub.count; ++n) {
    const double ex = ex_c + sub.dx[static_cast<std::size_t>(n)];
    const double ey = ey_c + sub.dy[static_cast<std::size_t>(n)];
    const double a1 = G.c1 * ex + G.s1 * ey, a2 = G.c2 * ex + G.s2 * ey;
    const double mu1 = a1 * G.inv_s_eff, mu2 = a2 * G.inv_s_eff;
    if (std::abs(mu1) > kFar && std::abs(mu2) > kFar) {  // as Corner() would say, without the call
      out.f += FarSign(shape, mu1, mu2);
      continue;
    }
    const CornerProfile f = ShapeProfile(shape, pr, mu1, mu2);
    out.f += f.f;
    if (f.df_dmu1 == 0.0 && f.df_dmu2 == 0.0 && f.df_drho == 0.0) continue;
    // d d_i / d c = -n_i; d d_i / d th_i = t_i . (x - c) = b_i with t_i = (-sin th_i, cos th_i).
    const double b1 = -G.s1 * ex + G.c1 * ey, b2 = -G.s2 * ex + G.c2 * ey;
    out.du -= f.df_dmu1 * G.c1 + f.df_dmu2 * G.c2;
    out.dv -= f.df_dmu1 * G.s1 + f.df_dmu2 * G.s2;
    out.dth1 += f.df_dmu1 * b1 * G.inv_s_eff - f.df_drho * G.sin12;
    out.dth2 += f.df_dmu2 * b2 * G.inv_s_eff + f.df_drho * G.sin12;
    out.ds -= f.df_dmu1 * mu1 + f.df_dmu2 * mu2;
  }
  // du, dv still lack their common factor 1 / s_eff, ds its d mu / d s = -mu / s_eff * ds_eff / ds.
  const double inv = 1.0 / sub.count, inv_s = inv * G.inv_s_eff;
  out.f *= inv;
  out.du *= inv_s;
  out.dv *= inv_s;
  out.dth1 *= inv;
  out.dth2 *= inv;
  out.ds *= inv_s * G.ds_eff_ds;
  return true;
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

// Per-fit buffers of Accumulate (one per cell of the window's grid).
struct Scratch {
  std::vector<PixelProfile> cells;
  std::vector<char> edge;  // the cell has derivatives (not far from both edges)
  std::vector<char> kind;  // CellKind, chosen at `at` with a margin
  CornerCache corners;     // the one-edge cells' pixel corners at the current evaluation
  bool classified = false;
  int generation = 0;  // counts the classifications
  Vec at = Vec::Zero();
};

// The cells' kinds at p, each with kClassMarginPx to spare: re-chosen when the corner has moved
// by more than half the margin, an edge turned by more than 0.005 rad, or s_eff grew by 10 %.
constexpr double kClassMarginPx = 0.3;
// Classified over win.reached, which holds the cells of both Accumulate modes.
void Classify(const Vec& p, const Geometry& G, const Window& win, Scratch* scratch) {
  const std::vector<char>& use = win.reached;
  const Vec& q = scratch->at;
  if (scratch->classified && std::hypot(p[kU] - q[kU], p[kV] - q[kV]) < 0.5 * kClassMarginPx &&
      std::abs(p[kTh1] - q[kTh1]) < 5e-3 && std::abs(p[kTh2] - q[kTh2]) < 5e-3 && p[kS] <= q[kS] * 1.1)
    return;
  scratch->classified = true;
  ++scratch->generation;
  scratch->at = p;
  scratch->at[kS] = std::max(p[kS], kMinBlurPx);
  const double s_eff = 1.0 / G.inv_s_eff;
  const double far_px = kFar * s_eff * 1.1 + 0.5 * std::numbers::sqrt2 + kClassMarginPx;
  scratch->kind.assign(use.size(), kFarBoth);
  for (int iy = 0; iy < win.ny; ++iy)
    for (int ix = 0; ix < win.nx; ++ix) {
      const std::size_t c = static_cast<std::size_t>(iy * win.nx + ix);
      if (!use[c]) continue;
      const double ex = win.dx0 + ix - p[kU], ey = win.dy0 + iy - p[kV];
      const bool near1 = std::abs(G.c1 * ex + G.s1 * ey) <= far_px, near2 = std::abs(G.c2 * ex + G.s2 * ey) <= far_px;
      scratch->kind[c] = near1 && near2 ? kNearBoth : near1 ? kNear1 : near2 ? kNear2 : kFarBoth;
    }
}

// H's rows (all of each: Accumulate reads the upper triangle).
using HRows = std::array<std::array<double, kNumParams>, kNumParams>;

// H += w J J^T and g += w r J over J's entries from kFirst on (0, or kM when only the levels,
// the gradient and a act). Written out with full rows of a fixed length, which the compiler
// vectorizes: the triangle's rows of varying length did not, and the 10 x 10 and 5 x 5 products
// through Eigen's general path cost a tenth of the fit. These updates are ~30 % of the fit.
template <int kFirst>
void RankOne(double w, double r, const Vec& __restrict__ J, HRows* __restrict__ h, std::array<double, kNumParams>* __restrict__ g) {
  for (std::size_t i = kFirst; i < static_cast<std::size_t>(kNumParams); ++i) {
    const double wj = w * J[static_cast<Eigen::Index>(i)];
    (*g)[i] += wj * r;
    std::array<double, kNumParams>& row = (*h)[i];
    for (std::size_t j = kFirst; j < static_cast<std::size_t>(kNumParams); ++j) row[j] += wj * J[static_cast<Eigen::Index>(j)];
  }
}

// Weighted sum of squared residuals and the normal equations H, g at p.
// With the 3-tap kernel, a pixel's profile is sum_kl w_k w_l F(cell + (k, l)), w = [a, 1 - 2a, a].
double Accumulate(const Vec& p, const Window& win, const SubSamples& sub, CornerShape shape, bool taps,
                  Scratch* scratch, Mat* H, Vec* g, bool classify = true) {
  const PreparedRho pr(Rho(p));
  const Geometry G(p, sub);
  const std::vector<char>& use = taps ? win.reached : win.needed;
  std::vector<PixelProfile>& cells = scratch->cells;
  std::vector<char>& edge = scratch->edge;
  if (classify || !scratch->classified) Classify(p, G, win, scratch);
  cells.resize(use.size());
  edge.resize(use.size());
  scratch->corners.Start(win, p);
  for (int iy = 0; iy < win.ny; ++iy)
    for (int ix = 0; ix < win.nx; ++ix) {
      const std::size_t c = static_cast<std::size_t>(iy * win.nx + ix);
      if (use[c])
        edge[c] = Profile(p, G, pr, sub, shape, win.dx0 + ix, win.dy0 + iy, scratch->kind[c], CellAt{&scratch->corners, ix, iy},
                          &cells[c])
                      ? 1
                      : 0;
    }
  const double a = taps ? p[kA] : 0.0;
  const std::array<double, 3> w{a, 1.0 - 2.0 * a, a}, dw{1.0, -2.0, 1.0};
  double cost = 0.0;
  Vec J;
  alignas(16) HRows h{};
  std::array<double, kNumParams> gg{};
  for (const Pixel& px : win.pixels) {
    PixelProfile f;
    double df_da = 0.0;
    bool any_edge = false;
    if (taps) {
      for (int l = -1; l <= 1; ++l)
        for (int k = -1; k <= 1; ++k) {
          const std::size_t c = static_cast<std::size_t>(px.cell + l * win.nx + k);
          const PixelProfile& q = cells[c];
          const std::size_t ik = static_cast<std::size_t>(k + 1), il = static_cast<std::size_t>(l + 1);
          if (edge[c]) {
            AddScaled(w[ik] * w[il], q, &f);
            any_edge = true;
          } else {
            f.f += w[ik] * w[il] * q.f;
          }
          df_da += (dw[ik] * w[il] + w[ik] * dw[il]) * q.f;
        }
    } else {
      f = cells[static_cast<std::size_t>(px.cell)];
      any_edge = edge[static_cast<std::size_t>(px.cell)] != 0;
    }
    const double L = 1.0 + p[kGx] * px.dx + p[kGy] * px.dy;
    const double B = p[kM] + p[kH] * f.f;
    const double r = L * B - px.value;
    cost += px.w * r * r;
    const double lh = L * p[kH];
    J[kM] = L;
    J[kH] = L * f.f;
    J[kGx] = px.dx * B;
    J[kGy] = px.dy * B;
    J[kA] = lh * df_da;
    // Far from both edges only the levels, the gradient and a act (m .. a, the last five).
    static_assert(kM == kNumParams - 5 && kA == kNumParams - 1);
    int first = kM;
    if (any_edge) {
      J[kU] = lh * f.du;
      J[kV] = lh * f.dv;
      J[kTh1] = lh * f.dth1;
      J[kTh2] = lh * f.dth2;
      J[kS] = lh * f.ds;
      first = 0;
    }
    if (first == 0) {
      RankOne<0>(px.w, r, J, &h, &gg);
    } else {
      RankOne<kM>(px.w, r, J, &h, &gg);
    }
  }
  for (int i = 0; i < kNumParams; ++i) {
    (*g)[i] = gg[static_cast<std::size_t>(i)];
    for (int j = i; j < kNumParams; ++j) (*H)(i, j) = (*H)(j, i) = h[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
  }
  return cost;
}

double PixelValue(const cv::Mat& image, int x, int y) {
  return image.type() == CV_8UC1 ? static_cast<double>(image.at<unsigned char>(y, x))
                                 : static_cast<double>(image.at<unsigned short>(y, x));
}

Eigen::Vector2d Perp(const Eigen::Vector2d& e) { return Eigen::Vector2d(-e.y(), e.x()); }

// An empty window over the pixel box [x_lo, x_hi] x [y_lo, y_hi], positions relative to uv0.
Window EmptyWindow(const Eigen::Vector2d& uv0, int x_lo, int x_hi, int y_lo, int y_hi) {
  Window win;
  win.x_lo = x_lo;
  win.x_hi = x_hi;
  win.y_lo = y_lo;
  win.y_hi = y_hi;
  win.nx = x_hi - x_lo + 3;
  win.ny = y_hi - y_lo + 3;
  win.dx0 = (x_lo - 1) - uv0.x();
  win.dy0 = (y_lo - 1) - uv0.y();
  win.needed.assign(static_cast<std::size_t>(std::max(win.nx, 0) * std::max(win.ny, 0)), 0);
  return win;
}

// Adds pixel (x, y) of the box with weight w (none when w <= 0).
void AddPixel(const cv::Mat& image, const Eigen::Vector2d& uv0, int x, int y, double w, Window* win) {
  if (!(w > 0.0)) return;
  const int cell = (y - win->y_lo + 1) * win->nx + (x - win->x_lo + 1);
  win->pixels.push_back({x - uv0.x(), y - uv0.y(), PixelValue(image, x, y), w, cell});
  win->needed[static_cast<std::size_t>(cell)] = 1;
}

// The cells the 3-tap kernel reaches from the window's pixels.
void FinishWindow(Window* win) {
  win->reached.assign(win->needed.size(), 0);
  for (const Pixel& px : win->pixels)
    for (int l = -1; l <= 1; ++l)
      for (int k = -1; k <= 1; ++k) win->reached[static_cast<std::size_t>(px.cell + l * win->nx + k)] = 1;
}

// The Levenberg-Marquardt step for the normal equations H dp = -g with Marquardt's diagonal
// scaling by lambda; parameters not free or held at a bound get dp = 0. False: H is singular.
bool DampedStep(const Mat& H, const Vec& g, const std::array<bool, kNumParams>& free,
                const std::array<bool, kNumParams>& held, double lambda, Vec* dp) {
  Mat A = H;
  Vec rhs = -g;
  for (int i = 0; i < kNumParams; ++i) {
    if (!free[static_cast<std::size_t>(i)] || held[static_cast<std::size_t>(i)]) {
      A.row(i).setZero();
      A.col(i).setZero();
      A(i, i) = 1.0;
      rhs[i] = 0.0;
    } else {
      A(i, i) += lambda * std::max(H(i, i), 1e-12);
    }
  }
  const Eigen::LDLT<Mat> ldlt(A);
  if (ldlt.info() != Eigen::Success) return false;
  *dp = ldlt.solve(rhs);
  return true;
}

// Fits the model of `shape` to the window's pixels from the corner uv0 and the edges' normals
// n1, n2 (unit; for kL pointing out of the dark quadrant); fit carries uv0 and the window's radius
// and, when fit.blur_px > 0, the blur and kernel to start from (else a sharp start).
CornerFit FitCorner(const Window& win, const Eigen::Vector2d& uv0, const Eigen::Vector2d& n1, const Eigen::Vector2d& n2,
                    CornerShape shape, const CornerRefineOptions& o, CornerFit fit) {
  const std::vector<Pixel>& pixels = win.pixels;
  Vec p = Vec::Zero();
  // Start: the given edges, a sharp blur, then the levels by linear least squares.
  p[kTh1] = std::atan2(n1.y(), n1.x());
  p[kTh2] = std::atan2(n2.y(), n2.x());
  // A sharp start: the first evaluations cost in proportion to the blur (the edge profiles' reach),
  // and the simulated and the measured images fit s ~0.1-0.15 px (the 3-tap kernel and the pixel
  // area carry most of the blur). Blurrier optics are reached from it (corner_refine_test).
  p[kS] = fit.blur_px > 0.0 ? fit.blur_px : 0.25;
  p[kA] = fit.blur_px > 0.0 ? std::clamp(fit.kernel_a, 0.0, kMaxTap) : 0.0;
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
      const double f = ShapeProfile(shape, pr, (c1 * px.dx + s1 * px.dy) / p[kS], (c2 * px.dx + s2 * px.dy) / p[kS]).f;
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
  // s's lower bound: kMinBlurPx says why.
  const double s_min = kMinBlurPx;
  std::array<bool, kNumParams> free{};
  free.fill(true);
  free[kGx] = free[kGy] = o.fit_gradient;
  free[kA] = o.fit_pixel_kernel;
  Mat H;
  Vec g;
  Scratch scratch;
  double cost = Accumulate(p, win, sub, shape, o.fit_pixel_kernel, &scratch, &H, &g);
  double lambda = 1e-3;
  bool converged = false;
  int it = 0;
  // Corner positions of the last accepted steps: the blur's shape parameters can creep along a
  // shallow valley for many steps after the corner has settled.
  constexpr int kSettle = 8;
  std::array<Eigen::Vector2d, kSettle> recent{};
  int accepted_steps = 0;
  // Or: the corner's Gauss-Newton steps have shrunk below 10 x then 1 x converged_step_px (they
  // shrink geometrically, so it has < ~converged_step_px left to move: far below the noise).
  double last_step_px = 1e9;
  for (; it < o.max_iterations && !converged; ++it) {
    bool accepted = false;
    // A bounded parameter at its bound that the descent direction -g pushes outwards is held
    // there for this step (an active set): clamping the free step instead made LM raise its
    // damping and crawl, e.g. a at 0.25 and s at s_min on dim, blurry images (16 -> 8 iterations).
    std::array<bool, kNumParams> held{};
    held[kS] = p[kS] <= s_min && g[kS] > 0.0;
    held[kA] = (p[kA] <= 0.0 && g[kA] > 0.0) || (p[kA] >= kMaxTap && g[kA] < 0.0);
    for (int tries = 0; tries < 12 && !accepted; ++tries) {
      Vec dp;
      if (!DampedStep(H, g, free, held, lambda, &dp)) break;
      Vec q = p + dp;
      q[kS] = std::max(q[kS], s_min);
      q[kA] = std::clamp(q[kA], 0.0, kMaxTap);
      if (!dp.allFinite() || !(std::abs(Rho(q)) < kMaxAbsRho)) {
        lambda *= 10.0;
        continue;
      }
      // Nearly Gauss-Newton (the diagonal raised by <= 10 %): a small step is then not just damped.
      // Dim, blurry images settle at 1e-2..1e-1 (s and a trade along a valley).
      const bool gauss_newton = lambda <= 0.1;
      const double step_px = std::hypot(dp[kU], dp[kV]);
      // The corner's Gauss-Newton steps have shrunk below 10 x then 1 x converged_step_px: this
      // last one is taken without evaluating its cost (in the quadratic regime it lowers it; the
      // evaluation was a fifth of the fit and changed nothing).
      if (gauss_newton && step_px < o.converged_step_px && last_step_px < 10.0 * o.converged_step_px) {
        p = q;
        converged = accepted = true;
        break;
      }
      // The normal equations come with the trial's cost: nearly every trial step is taken.
      Mat Hq;
      Vec gq;
      const int generation = scratch.generation;
      const double new_cost = Accumulate(q, win, sub, shape, o.fit_pixel_kernel, &scratch, &Hq, &gq);
      // The cells' models were re-chosen at q: compare with p under the same ones.
      if (scratch.generation != generation)
        cost = Accumulate(p, win, sub, shape, o.fit_pixel_kernel, &scratch, &H, &g, false);
      if (new_cost <= cost) {
        accepted = true;
        const double decrease = cost - new_cost;
        p = q;
        cost = new_cost;
        H = Hq;
        g = gq;
        lambda = std::max(lambda / 10.0, 1e-9);
        // Converged when the corner and the edges have stopped moving.
        converged = step_px < 1e-6 && std::abs(dp[kTh1]) + std::abs(dp[kTh2]) < 1e-7;
        last_step_px = gauss_newton ? step_px : 1e9;
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

void CornerRefineStats::Add(const CornerRefineStats& other) {
  for (std::size_t i = 0; i < count.size(); ++i) count[i] += other.count[i];
}

std::string ToString(const CornerRefineStats& s) {
  std::string out = std::to_string(s.Refined()) + " refined, " + std::to_string(s.Kept()) + " kept";
  std::string reasons;
  for (std::size_t i = 1; i < s.count.size(); ++i)
    if (s.count[i] > 0)
      reasons += (reasons.empty() ? "" : ", ") + std::to_string(s.count[i]) + " " +
                 ToString(static_cast<CornerRefineStatus>(i));
  return reasons.empty() ? out : out + " (" + reasons + ")";
}

double BivariateNormalCdf(double h, double k, double rho) {
  if (!(std::abs(rho) <= kMaxAbsRho)) throw std::invalid_argument("BivariateNormalCdf: |rho| must be <= 0.95");
  return PreparedRho(rho).Cdf(h, k);
}

PixelEdge PixelAveragedEdge(double d, double theta, double sigma) {
  if (!(sigma > 0.0)) throw std::invalid_argument("PixelAveragedEdge: sigma must be > 0");
  return BoxAveragedEdge(d, std::cos(theta), std::sin(theta), sigma, ErfcxTable());
}

CornerProfile BlurredCorner(double mu1, double mu2, double rho, CornerShape shape) {
  if (!(std::abs(rho) <= kMaxAbsRho)) throw std::invalid_argument("BlurredCorner: |rho| must be <= 0.95");
  return ShapeProfile(shape, PreparedRho(rho), mu1, mu2);
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
  Window win = EmptyWindow(uv0, static_cast<int>(std::ceil(uv0.x() - r)), static_cast<int>(std::floor(uv0.x() + r)),
                           static_cast<int>(std::ceil(uv0.y() - r)), static_cast<int>(std::floor(uv0.y() + r)));
  for (int y = win.y_lo; y <= win.y_hi; ++y)
    for (int x = win.x_lo; x <= win.x_hi; ++x) AddPixel(image, uv0, x, y, Taper(std::hypot(x - uv0.x(), y - uv0.y()), r), &win);
  FinishWindow(&win);
  // The X-corner's model is the same for either sign of each normal (h and rho follow).
  return FitCorner(win, uv0, Perp(edge1_px).normalized(), Perp(edge2_px).normalized(), CornerShape::kX, o, fit);
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

namespace {

// Weight along an arm of length A at distance t >= 0 from the corner: the window's flat top and
// cosine taper (Taper), so that no pixel enters or leaves the fit abruptly as the arm ends.
double ArmWeight(double t, double A) { return Taper(std::max(t, 0.0), A); }

// A tag corner's geometry: outward unit normals of its two edges (d_i = n_i . (x - c) < 0
// inside the tag) and the tag's width across each (its border cell is 1/8 of it, the gap
// beyond the edge tag_spacing of it).
struct TagCorner {
  Eigen::Vector2d c, n1, n2;
  double w1 = 0.0, w2 = 0.0;
};

// The window of a tag corner whose arms keep `margin` px from the pattern's other edges and reach
// at most `strip` px across their edge; false (fit->status kWindowTooSmall) when too small or cut.
bool TagWindow(const cv::Mat& image, const TagCorner& t, double tag_spacing, double margin, double strip,
               const CornerRefineOptions& o, Window* win, CornerFit* fit) {
  fit->status = CornerRefineStatus::kWindowTooSmall;
  // Each arm's reach across its edge, inwards (to the border cell's inner side) and outwards
  // (to the gap's far side), less the margin, at most `strip`: beyond the edge's blurred
  // profile a pixel only adds to the levels (and to the cost: 2.3x for the dataset's tags).
  const double b1 = std::min(t.w1 / 8.0 - margin, strip), b2 = std::min(t.w2 / 8.0 - margin, strip);
  const double g1 = std::min(tag_spacing * t.w1 - margin, strip), g2 = std::min(tag_spacing * t.w2 - margin, strip);
  const double a1 = std::min(o.tag_arm_fraction * t.w2, o.tag_max_arm_px);  // arm along edge 1 (in -d2)
  const double a2 = std::min(o.tag_arm_fraction * t.w1, o.tag_max_arm_px);  // arm along edge 2 (in -d1)
  fit->radius_px = std::max(a1, a2);
  if (!(std::min({b1, b2, g1, g2}) >= o.tag_min_strip_px) || !(std::min(a1, a2) >= o.min_radius_px)) return false;
  // The pixels of the two arms: arm 1 (along edge 1) spans d1 in (-b1, g1), d2 in (-a1, g2);
  // arm 2 likewise.
  Eigen::Matrix2d N;
  N << t.n1.transpose(), t.n2.transpose();
  const Eigen::Matrix2d Ninv = N.inverse();
  // Their bounding box, cut to the image; the block round the corner (both strips' crossing,
  // reaching as far outwards as inwards) must lie inside it, the rest may be cut by the border.
  auto box = [&](std::initializer_list<Eigen::Vector2d> ds) {
    Eigen::AlignedBox2d bx;
    for (const Eigen::Vector2d& d : ds) bx.extend(t.c + Ninv * d);
    return bx;
  };
  const Eigen::AlignedBox2d image_box(Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(image.cols - 1.0, image.rows - 1.0));
  const double o1 = std::min(g1, b1), o2 = std::min(g2, b2);
  if (!image_box.contains(box({{-b1, -b2}, {o1, -b2}, {-b1, o2}, {o1, o2}}))) return false;
  const Eigen::AlignedBox2d arms = box({{-b1, -a1}, {g1, -a1}, {-b1, g2}, {-a2, -b2}, {-a2, g2}, {g1, g2}}).intersection(image_box);
  *win = EmptyWindow(t.c, static_cast<int>(std::ceil(arms.min().x())), static_cast<int>(std::floor(arms.max().x())),
                     static_cast<int>(std::ceil(arms.min().y())), static_cast<int>(std::floor(arms.max().y())));
  for (int y = win->y_lo; y <= win->y_hi; ++y)
    for (int x = win->x_lo; x <= win->x_hi; ++x) {
      const Eigen::Vector2d d = N * (Eigen::Vector2d(x, y) - t.c);
      const bool outer = d.x() < g1 && d.y() < g2;
      const double w_arm1 = outer && d.x() > -b1 ? ArmWeight(-d.y(), a1) : 0.0;
      const double w_arm2 = outer && d.y() > -b2 ? ArmWeight(-d.x(), a2) : 0.0;
      AddPixel(image, t.c, x, y, std::max(w_arm1, w_arm2), win);
    }
  FinishWindow(win);
  return true;
}

// The fitted corner's blur as one Gaussian sigma (px): the optics' s, the pixel's area (1/12) and
// the 3-tap kernel's variance (2a), per axis.
double TotalBlurPx(const CornerFit& f) { return std::sqrt(f.blur_px * f.blur_px + 1.0 / 12.0 + 2.0 * f.kernel_a); }

}  // namespace

CornerFit RefineTagCorner(const cv::Mat& image, const Eigen::Vector2d& uv0, const Eigen::Vector2d& along1_px,
                          const Eigen::Vector2d& along2_px, double tag_spacing, bool corner_squares,
                          const CornerRefineOptions& o, const CornerFit* prior) {
  if (image.type() != CV_8UC1 && image.type() != CV_16UC1)
    throw std::invalid_argument("RefineTagCorner: image must be CV_8UC1 or CV_16UC1");
  CornerFit fit;
  fit.uv = uv0;
  fit.status = CornerRefineStatus::kWindowTooSmall;
  TagCorner t{uv0, Perp(along1_px), Perp(along2_px)};
  if (!uv0.allFinite() || !(t.n1.norm() > 1.0) || !(t.n2.norm() > 1.0)) return fit;
  t.n1.normalize();
  t.n2.normalize();
  if (t.n1.dot(along2_px) > 0) t.n1 = -t.n1;
  if (t.n2.dot(along1_px) > 0) t.n2 = -t.n2;
  t.w1 = std::abs(t.n1.dot(along2_px));
  t.w2 = std::abs(t.n2.dot(along1_px));
  if (prior != nullptr && prior->status == CornerRefineStatus::kRefined) {
    fit.blur_px = prior->blur_px;
    fit.kernel_a = prior->kernel_a;
  }
  const CornerShape shape = corner_squares ? CornerShape::kX : CornerShape::kL;
  Window win;
  if (!TagWindow(image, t, tag_spacing, o.tag_margin_px, o.tag_strip_px, o, &win, &fit)) return fit;
  CornerFit out = FitCorner(win, uv0, t.n1, t.n2, shape, o, fit);
  // Blurrier optics than the margin allows for (beyond 2 sigma the next edge leaks < 2 % of its
  // contrast into the window's rim): the window again with margins and strips of 3 sigma, the
  // fit from this one's blur and kernel.
  const double sigma = TotalBlurPx(out);
  if (out.status != CornerRefineStatus::kRefined || !(2.0 * sigma > o.tag_margin_px)) return out;
  const double wide = 3.0 * sigma;
  fit.blur_px = out.blur_px;
  fit.kernel_a = out.kernel_a;
  if (!TagWindow(image, t, tag_spacing, wide, std::max(o.tag_strip_px, wide), o, &win, &fit)) return fit;
  return FitCorner(win, uv0, t.n1, t.n2, shape, o, fit);
}

std::vector<CornerFit> RefineAprilGridCorners(const cv::Mat& image, const AprilGridSpec& spec,
                                              const std::vector<std::array<Eigen::Vector2d, 4>>& tags,
                                              const CornerRefineOptions& o, CornerRefineStats* stats) {
  if (image.type() != CV_8UC1 && image.type() != CV_16UC1)
    throw std::invalid_argument("RefineAprilGridCorners: image must be CV_8UC1 or CV_16UC1");
  std::vector<CornerFit> out;
  out.reserve(4 * tags.size());
  // The last refined corner (a copy: out grows): its blur and kernel start the next fit.
  // RefineTagCorner ignores a prior that is not kRefined, as this one is until a fit succeeds.
  CornerFit prior;
  for (const std::array<Eigen::Vector2d, 4>& q : tags)
    for (std::size_t k = 0; k < 4; ++k) {
      // libapriltag's corners go round the tag: the neighbours along its edges are k +- 1.
      const Eigen::Vector2d& c = q[k];
      out.push_back(RefineTagCorner(image, c, q[(k + 1) % 4] - c, q[(k + 3) % 4] - c, spec.tag_spacing,
                                    spec.corner_squares, o, &prior));
      if (stats != nullptr) ++stats->count[static_cast<std::size_t>(out.back().status)];
      if (out.back().status == CornerRefineStatus::kRefined) prior = out.back();
    }
  return out;
}

}  // namespace mfns::host
