// Test-only copy of the pre-algebraic generalized P3P (see p3p_scan_reference.h).
#include "firmware/modules/identify/p3p_scan_reference.h"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

namespace mfns::fw::scan_reference {

// Along ray 1 at depth l, with u_k = o1 - o_k:  m_k(l) = d_k . (P1 - o_k) = a_k + b_k l and
// |P1 - o_k|^2 = c_k + 2 e_k l + l^2, so q_k(l) = |P1 - o_k|^2 - m_k^2 (the squared distance of
// P1 from ray k) is a quadratic in l.
ScanP3p::Sample ScanP3p::At(double l1) const {
  Sample s;
  s.l1 = l1;
  s.m2 = ray2_.a + ray2_.b * l1;
  s.q2 = std::max(0.0, ray2_.c + (2.0 * ray2_.e + l1) * l1 - s.m2 * s.m2);
  s.m3 = ray3_.a + ray3_.b * l1;
  s.q3 = std::max(0.0, ray3_.c + (2.0 * ray3_.e + l1) * l1 - s.m3 * s.m3);
  return s;
}

bool ScanP3p::Set(const std::array<BodyRay, 3>& rays, const P3pOptions& options) {
  n_ = 0;
  if (!options.IsValid()) return false;
  rays_ = rays;
  options_ = options;
  auto coefficients = [&](const BodyRay& r) {
    const Eigen::Vector3d u = rays[0].o_b - r.o_b;
    return RayCoefficients{r.d_b.dot(u), r.d_b.dot(rays[0].d_b), u.squaredNorm(), rays[0].d_b.dot(u)};
  };
  ray2_ = coefficients(rays[1]);
  ray3_ = coefficients(rays[2]);
  const Eigen::Vector3d o23 = rays[1].o_b - rays[2].o_b;
  o23_sq_ = o23.squaredNorm();
  d2_o23_ = rays[1].d_b.dot(o23);
  d3_o23_ = rays[2].d_b.dot(o23);
  d2_d3_ = rays[1].d_b.dot(rays[2].d_b);
  // One camera: the closed form (SolveCentral) needs no scan.
  const double scale = 1.0 + rays[0].o_b.norm();
  central_ = (rays[1].o_b - rays[0].o_b).norm() <= 1e-12 * scale && (rays[2].o_b - rays[0].o_b).norm() <= 1e-12 * scale;
  cos_a_ = rays[1].d_b.dot(rays[2].d_b);
  cos_b_ = rays[0].d_b.dot(rays[2].d_b);
  cos_c_ = rays[0].d_b.dot(rays[1].d_b);
  if (central_) {
    n_ = options.scan_steps;
    return true;
  }
  // Geometric grid: the same relative depth resolution near and far (computed once per depth
  // range).
  if (options.min_depth_m != grid_min_ || options.max_depth_m != grid_max_ || options.scan_steps != grid_n_) {
    const double ratio = std::log(options.max_depth_m / options.min_depth_m);
    for (int j = 0; j < options.scan_steps; ++j)
      depth_grid_[static_cast<std::size_t>(j)] = options.min_depth_m * std::exp(ratio * j / (options.scan_steps - 1));
    grid_min_ = options.min_depth_m;
    grid_max_ = options.max_depth_m;
    grid_n_ = options.scan_steps;
  }
  for (int j = 0; j < options.scan_steps; ++j) grid_[static_cast<std::size_t>(j)] = At(depth_grid_[static_cast<std::size_t>(j)]);
  n_ = options.scan_steps;
  return true;
}

namespace {

// Depth along ray 2 or 3 on branch s; false where the discriminant is negative (no point of
// the ray at distance D), with a rounding allowance at the branch's end. Depths below the
// minimum are refused only at emission, so that the residual stays one smooth function per
// branch up to the branch's end.
bool Branch(double m, double q, double D_sq, int s, double* l) {
  double disc = D_sq - q;
  if (disc < 0.0) {
    if (disc < -1e-12 * (D_sq + q)) return false;
    disc = 0.0;
  }
  *l = m + s * std::sqrt(disc);
  return true;
}

// Real roots of A x^2 + B x + C = 0 (A may vanish); returns how many.
int Quadratic(double A, double B, double C, double* x0, double* x1) {
  if (std::abs(A) < 1e-14 * (std::abs(B) + std::abs(C))) {
    if (B == 0.0) return 0;
    *x0 = *x1 = -C / B;
    return 1;
  }
  const double disc = B * B - 4.0 * A * C;
  if (disc < 0.0) return 0;
  // Numerically stable form.
  const double q = -0.5 * (B + std::copysign(std::sqrt(disc), B));
  *x0 = q / A;
  *x1 = q != 0.0 ? C / q : *x0;
  return 2;
}

// Whether the extremum of f between three samples may reach zero (most extrema are far from
// zero and skipped): the vertex of the parabola through them lies between them and crosses
// zero, or the middle sample is nearer zero than to its farther neighbour.
bool DipMayCross(double x0, double f0, double x1, double f1, double x2, double f2) {
  const double s01 = (f1 - f0) / (x1 - x0), s12 = (f2 - f1) / (x2 - x1);
  const double curv = (s12 - s01) / (x2 - x0);  // half the second derivative
  if (curv == 0.0) return false;
  // f(x) = f1 + s (x - x1) + curv (x - x1)^2 with s the slope at x1 of the parabola.
  const double s = s01 + curv * (x1 - x0);
  const double xv = x1 - s / (2.0 * curv);  // the vertex
  const double slack = 0.5 * std::abs(x2 - x0);
  if (xv < std::min(x0, x2) - slack || xv > std::max(x0, x2) + slack) return false;
  const double fv = f1 - s * s / (4.0 * curv);
  // Near a (double) root f is V-shaped rather than parabolic: also search when the middle
  // sample is closer to zero than to its farther neighbour.
  return (fv >= 0.0) != (f1 >= 0.0) || std::abs(f1) < std::max(std::abs(f0 - f1), std::abs(f2 - f1));
}

}  // namespace

bool ScanP3p::Eval(double l1, int s2, int s3, const Distances& D, double* f, double* l2, double* l3) const {
  const Sample s = At(l1);
  if (!Branch(s.m2, s.q2, D.d12_sq, s2, l2) || !Branch(s.m3, s.q3, D.d13_sq, s3, l3)) return false;
  const double d_sq = o23_sq_ + *l2 * *l2 + *l3 * *l3 + 2.0 * *l2 * d2_o23_ - 2.0 * *l3 * d3_o23_ -
                      2.0 * *l2 * *l3 * d2_d3_;
  *f = d_sq - D.d23_sq;  // same sign as |P2 - P3| - D23
  return true;
}

// The depth l1 in [lo, hi] where a discriminant of ray 2 or 3 vanishes, nearest to `near`:
// q_k(l1) = D_k^2 is a quadratic in l1. False if none lies in the interval.
bool ScanP3p::BranchEnd(double lo, double hi, double near, const Distances& D, double* l1) const {
  bool found = false;
  double best = 0.0;
  auto consider = [&](const RayCoefficients& r, double D_sq) {
    double x[2] = {0.0, 0.0};
    const int n = Quadratic(1.0 - r.b * r.b, 2.0 * (r.e - r.a * r.b), r.c - r.a * r.a - D_sq, &x[0], &x[1]);
    for (int i = 0; i < n; ++i) {
      if (x[i] < lo || x[i] > hi) continue;
      if (!found || std::abs(x[i] - near) < std::abs(best - near)) best = x[i];
      found = true;
    }
  };
  consider(ray2_, D.d12_sq);
  consider(ray3_, D.d13_sq);
  *l1 = best;
  return found;
}

// Root of f on [a, b] (valid at both ends, opposite signs) by the Illinois variant of regula
// falsi (superlinear, bracketing), to about 1e-13 relative.
bool ScanP3p::Root(double a, double b, int s2, int s3, const Distances& D, double* l1) const {
  double fa = 0.0, fb = 0.0, l2 = 0.0, l3 = 0.0;
  if (!Eval(a, s2, s3, D, &fa, &l2, &l3) || !Eval(b, s2, s3, D, &fb, &l2, &l3)) return false;
  if ((fa < 0.0) == (fb < 0.0)) return false;
  int side = 0;
  double c = a;
  for (int it = 0; it < limits::kMaxBisectionIterations; ++it) {
    double next = (a * fb - b * fa) / (fb - fa);
    if (!(next > std::min(a, b) && next < std::max(a, b))) next = 0.5 * (a + b);
    const bool done = std::abs(next - c) <= 1e-13 * std::abs(next);
    c = next;
    double fc = 0.0;
    if (!Eval(c, s2, s3, D, &fc, &l2, &l3)) return false;
    if (fc == 0.0 || done || std::abs(b - a) <= 1e-14 * std::abs(c)) break;
    if ((fc < 0.0) == (fb < 0.0)) {
      b = c;
      fb = fc;
      if (side == -1) fa *= 0.5;
      side = -1;
    } else {
      a = c;
      fa = fc;
      if (side == 1) fb *= 0.5;
      side = 1;
    }
  }
  *l1 = c;
  return true;
}

int ScanP3p::Solve(const std::array<Eigen::Vector3d, 3>& P_w,
                        std::array<BodyPose, limits::kMaxP3pSolutions>* poses,
                        std::array<Eigen::Vector3d, limits::kMaxP3pSolutions>* depths) const {
  if (central_) return n_ > 0 ? SolveCentral(P_w, poses, depths) : 0;
  const Distances D{(P_w[1] - P_w[0]).squaredNorm(), (P_w[2] - P_w[0]).squaredNorm(),
                    (P_w[2] - P_w[1]).squaredNorm()};
  int count = 0;
  std::array<double, limits::kMaxP3pSolutions> emitted_l1{};
  std::array<int, limits::kMaxP3pSolutions> emitted_branch{};
  auto emit = [&](double l1, int s2, int s3) {
    double f = 0.0, l2 = 0.0, l3 = 0.0;
    if (count >= limits::kMaxP3pSolutions || !Eval(l1, s2, s3, D, &f, &l2, &l3)) return;
    if (l2 < options_.min_depth_m || l3 < options_.min_depth_m) return;  // behind or too near
    const int branch = (s2 > 0 ? 1 : 0) + (s3 > 0 ? 2 : 0);
    for (int i = 0; i < count; ++i)  // one root found from two overlapping searches
      if (emitted_branch[static_cast<std::size_t>(i)] == branch &&
          std::abs(emitted_l1[static_cast<std::size_t>(i)] - l1) <= 1e-9 * l1)
        return;
    const std::array<Eigen::Vector3d, 3> q = {rays_[0].o_b + l1 * rays_[0].d_b, rays_[1].o_b + l2 * rays_[1].d_b,
                                              rays_[2].o_b + l3 * rays_[2].d_b};
    BodyPose pose;
    if (!TriangleOrientation(q, P_w, &pose)) return;
    (*poses)[static_cast<std::size_t>(count)] = pose;
    if (depths != nullptr) (*depths)[static_cast<std::size_t>(count)] = Eigen::Vector3d(l1, l2, l3);
    emitted_l1[static_cast<std::size_t>(count)] = l1;
    emitted_branch[static_cast<std::size_t>(count)] = branch;
    ++count;
  };

  // Square roots of the two discriminants, once per sample for all four branch pairs.
  std::array<double, limits::kMaxP3pScanSteps> r2{}, r3{}, f{};
  std::array<bool, limits::kMaxP3pScanSteps> ok{};
  for (int j = 0; j < n_; ++j) {
    const Sample& g = grid_[static_cast<std::size_t>(j)];
    const double disc2 = D.d12_sq - g.q2, disc3 = D.d13_sq - g.q3;
    const auto sj = static_cast<std::size_t>(j);
    ok[sj] = disc2 >= 0.0 && disc3 >= 0.0;
    r2[sj] = ok[sj] ? std::sqrt(disc2) : 0.0;
    r3[sj] = ok[sj] ? std::sqrt(disc3) : 0.0;
  }
  auto L = [&](int j) { return grid_[static_cast<std::size_t>(j)].l1; };
  auto F = [&](int j) { return f[static_cast<std::size_t>(j)]; };
  auto OK = [&](int j) { return j >= 0 && j < n_ && ok[static_cast<std::size_t>(j)]; };

  for (int c = 0; c < 4; ++c) {
    const int s2 = (c & 1) != 0 ? 1 : -1, s3 = (c & 2) != 0 ? 1 : -1;
    for (int j = 0; j < n_; ++j) {
      const Sample& g = grid_[static_cast<std::size_t>(j)];
      const double l2 = g.m2 + s2 * r2[static_cast<std::size_t>(j)];
      const double l3 = g.m3 + s3 * r3[static_cast<std::size_t>(j)];
      f[static_cast<std::size_t>(j)] =
          o23_sq_ + l2 * l2 + l3 * l3 + 2.0 * l2 * d2_o23_ - 2.0 * l3 * d3_o23_ - 2.0 * l2 * l3 * d2_d3_ - D.d23_sq;
    }
    // Roots on [lo, hi] (f valid at both ends) where f has the same sign at both ends: an
    // extremum heading towards zero may cross it twice.
    auto search_dip = [&](double lo, double hi, bool positive) {
      double x = 0.0, fx = 0.0, l1 = 0.0;
      if (!Extremum(lo, hi, s2, s3, D, positive, &x, &fx) || (fx >= 0.0) == positive) return;
      if (Root(lo, x, s2, s3, D, &l1)) emit(l1, s2, s3);
      if (Root(x, hi, s2, s3, D, &l1)) emit(l1, s2, s3);
    };
    for (int j = 1; j < n_; ++j) {
      double l1 = 0.0;
      if (OK(j - 1) && OK(j)) {
        const bool pos0 = F(j - 1) >= 0.0, pos1 = F(j) >= 0.0;
        if (pos0 != pos1) {
          if (Root(L(j - 1), L(j), s2, s3, D, &l1)) emit(l1, s2, s3);
        } else if (OK(j - 2) && (F(j - 2) >= 0.0) == pos0) {
          // Two roots inside one cell leave no sign change at the samples but an extremum
          // of f between j - 2 and j heading towards zero.
          const bool dip = pos0 ? (F(j - 1) < F(j - 2) && F(j - 1) < F(j)) : (F(j - 1) > F(j - 2) && F(j - 1) > F(j));
          if (dip && DipMayCross(L(j - 2), F(j - 2), L(j - 1), F(j - 1), L(j), F(j))) search_dip(L(j - 2), L(j), pos0);
        }
      } else if (OK(j - 1) != OK(j)) {
        // The branch ends inside the cell (a discriminant crosses zero, analytically located):
        // look for roots between the end and the valid samples next to it (f bends sharply
        // there, like a square root, so the cell before it is searched too).
        const int v = OK(j - 1) ? j - 1 : j;      // the valid sample
        const int w = OK(j - 1) ? j - 2 : j + 1;  // the one before it, away from the end
        double end = 0.0, f_end = 0.0, l2 = 0.0, l3 = 0.0;
        if (!BranchEnd(L(j - 1), L(j), L(v), D, &end) || !Eval(end, s2, s3, D, &f_end, &l2, &l3)) continue;
        const bool pos = F(v) >= 0.0;
        if ((f_end >= 0.0) != pos) {
          if (Root(std::min(L(v), end), std::max(L(v), end), s2, s3, D, &l1)) emit(l1, s2, s3);
        } else if (!OK(w) || (F(w) >= 0.0) != pos) {
          search_dip(std::min(L(v), end), std::max(L(v), end), pos);
        } else {
          // In t = sqrt(|end - l1|) the branch is smooth again: the parabola test applies.
          const double tw = std::sqrt(std::abs(end - L(w))), tv = std::sqrt(std::abs(end - L(v)));
          // Also when the end is nearer zero than the samples are to it: a dip just before
          // the end hides from the samples.
          if (DipMayCross(tw, F(w), tv, F(v), 0.0, f_end) || std::abs(f_end) < std::abs(F(v) - f_end))
            search_dip(std::min(L(w), end), std::max(L(w), end), pos);
        }
      }
    }
  }
  return count;
}

// Golden-section search for the minimum (minimum = true) or maximum of f on [a, b]; stops as
// soon as the extremum has crossed zero (the roots are then bracketed).
bool ScanP3p::Extremum(double a, double b, int s2, int s3, const Distances& D, bool minimum, double* x,
                            double* fx) const {
  constexpr double kInvPhi = 0.6180339887498949;
  const double sign = minimum ? 1.0 : -1.0;
  double l2 = 0.0, l3 = 0.0, f1 = 0.0, f2 = 0.0;
  double x1 = b - kInvPhi * (b - a), x2 = a + kInvPhi * (b - a);
  if (!Eval(x1, s2, s3, D, &f1, &l2, &l3) || !Eval(x2, s2, s3, D, &f2, &l2, &l3)) return false;
  for (int it = 0; it < limits::kMaxBisectionIterations && b - a > 1e-8 * b; ++it) {
    if ((f1 >= 0.0) != minimum || (f2 >= 0.0) != minimum) break;
    if (sign * f1 < sign * f2) {
      b = x2;
      x2 = x1;
      f2 = f1;
      x1 = b - kInvPhi * (b - a);
      if (!Eval(x1, s2, s3, D, &f1, &l2, &l3)) return false;
    } else {
      a = x1;
      x1 = x2;
      f1 = f2;
      x2 = a + kInvPhi * (b - a);
      if (!Eval(x2, s2, s3, D, &f2, &l2, &l3)) return false;
    }
  }
  const bool first = sign * f1 < sign * f2;
  *x = first ? x1 : x2;
  *fx = first ? f1 : f2;
  return true;
}

namespace {

// Product of polynomials a (degree na) and b (degree nb), coefficients lowest first.
template <std::size_t kOut>
void PolyMul(const double* a, int na, const double* b, int nb, std::array<double, kOut>* out) {
  out->fill(0.0);
  for (int i = 0; i <= na; ++i)
    for (int j = 0; j <= nb; ++j) (*out)[static_cast<std::size_t>(i + j)] += a[i] * b[j];
}

// Newton steps on the three depths s of a central P3P: |s_i y_i - s_j y_j|^2 = D_ij^2, i.e.
// s_i^2 + s_j^2 - 2 s_i s_j cos_ij = D_ij^2 (pairs (2,3), (1,3), (1,2) with cosines ca, cb, cg).
void PolishDepths(double ca, double cb, double cg, double a2, double b2, double c2, Eigen::Vector3d* s) {
  for (int it = 0; it < 2; ++it) {
    const double s1 = (*s)(0), s2 = (*s)(1), s3 = (*s)(2);
    const Eigen::Vector3d r(s2 * s2 + s3 * s3 - 2.0 * s2 * s3 * ca - a2, s1 * s1 + s3 * s3 - 2.0 * s1 * s3 * cb - b2,
                            s1 * s1 + s2 * s2 - 2.0 * s1 * s2 * cg - c2);
    Eigen::Matrix3d J;
    J << 0.0, 2.0 * (s2 - s3 * ca), 2.0 * (s3 - s2 * ca),  //
        2.0 * (s1 - s3 * cb), 0.0, 2.0 * (s3 - s1 * cb),   //
        2.0 * (s1 - s2 * cg), 2.0 * (s2 - s1 * cg), 0.0;
    const Eigen::Vector3d step = J.inverse() * r;  // (cofactors: a 3 x 3 needs no pivoting here)
    if (!step.allFinite()) return;
    *s -= step;
  }
}

}  // namespace

// Grunert: with s2 = u s1, s3 = v s1, W(v) = 1 + v^2 - 2 v cb, K1 = a^2/b^2, K2 = c^2/b^2,
// the distance equations over the (1,3) one read
//   E1: u^2 - 2 u v ca + v^2 = K1 W,    E2: u^2 - 2 u cg + 1 = K2 W.
// E1 - E2 is linear in u: u M = N with M = 2 (cg - v ca), N = 1 - v^2 + (K1 - K2) W; into E2
// times M^2: N^2 - 2 cg N M + (1 - K2 W) M^2 = 0, a quartic in v. For each root v > 0,
// s1 = b / sqrt(W) and u from E2's two roots (no division by M, which may vanish), kept when
// the depths satisfy all three distances (after two Newton steps).
int ScanP3p::SolveCentral(const std::array<Eigen::Vector3d, 3>& P_w,
                               std::array<BodyPose, limits::kMaxP3pSolutions>* poses,
                               std::array<Eigen::Vector3d, limits::kMaxP3pSolutions>* depths) const {
  const double a2 = (P_w[2] - P_w[1]).squaredNorm(), b2 = (P_w[2] - P_w[0]).squaredNorm();
  const double c2 = (P_w[1] - P_w[0]).squaredNorm();
  if (!(a2 > 0.0) || !(b2 > 0.0) || !(c2 > 0.0) || !std::isfinite(a2 + b2 + c2)) return 0;
  const double ca = cos_a_, cb = cos_b_, cg = cos_c_;
  const double K1 = a2 / b2, K2 = c2 / b2, k = K1 - K2;
  const double W[3] = {1.0, -2.0 * cb, 1.0};
  const double N[3] = {1.0 + k, -2.0 * k * cb, k - 1.0};
  const double M[2] = {2.0 * cg, -2.0 * ca};
  const double E[3] = {1.0 - K2, 2.0 * K2 * cb, -K2};  // 1 - K2 W
  std::array<double, 5> NN{}, M2{}, quartic{};
  std::array<double, 4> NM{};
  std::array<double, 5> EM2{};
  PolyMul(N, 2, N, 2, &NN);
  PolyMul(N, 2, M, 1, &NM);
  PolyMul(M, 1, M, 1, &M2);
  PolyMul(E, 2, M2.data(), 2, &EM2);
  for (std::size_t i = 0; i < 5; ++i) quartic[i] = NN[i] + EM2[i] - (i < 4 ? 2.0 * cg * NM[i] : 0.0);
  std::array<double, 4> vs{};
  const int nv = PolynomialRealRoots(quartic.data(), 4, vs.data());
  const std::array<Eigen::Vector3d, 3> y = {rays_[0].d_b, rays_[1].d_b, rays_[2].d_b};
  const Eigen::Vector3d& o = rays_[0].o_b;
  int count = 0;
  for (int i = 0; i < nv; ++i) {
    const double v = vs[static_cast<std::size_t>(i)];
    const double w = W[0] + v * (W[1] + v * W[2]);
    if (!(v > 0.0) || !(w > 0.0)) continue;
    const double s1 = std::sqrt(b2 / w);
    const double disc = cg * cg - 1.0 + K2 * w;
    if (disc < -1e-9) continue;
    const double root = std::sqrt(std::max(0.0, disc));
    for (int branch = 0; branch < (root > 0.0 ? 2 : 1) && count < limits::kMaxP3pSolutions; ++branch) {
      const double u = cg + (branch == 0 ? root : -root);
      Eigen::Vector3d s(s1, u * s1, v * s1);
      if (!(s.minCoeff() > 0.0)) continue;
      PolishDepths(ca, cb, cg, a2, b2, c2, &s);
      const double e_a = s(1) * s(1) + s(2) * s(2) - 2.0 * s(1) * s(2) * ca - a2;
      const double e_b = s(0) * s(0) + s(2) * s(2) - 2.0 * s(0) * s(2) * cb - b2;
      const double e_c = s(0) * s(0) + s(1) * s(1) - 2.0 * s(0) * s(1) * cg - c2;
      if (std::abs(e_a) > 1e-9 * a2 || std::abs(e_b) > 1e-9 * b2 || std::abs(e_c) > 1e-9 * c2) continue;
      if (s(0) < options_.min_depth_m || s(0) > options_.max_depth_m || s(1) < options_.min_depth_m ||
          s(2) < options_.min_depth_m)
        continue;
      const std::array<Eigen::Vector3d, 3> q = {o + s(0) * y[0], o + s(1) * y[1], o + s(2) * y[2]};
      BodyPose pose;
      if (!TriangleOrientation(q, P_w, &pose)) continue;
      bool same = false;  // both branches may polish onto one solution
      for (int j = 0; j < count && !same; ++j) {
        const BodyPose& p = (*poses)[static_cast<std::size_t>(j)];
        same = (p.r_w_wb - pose.r_w_wb).norm() <= 1e-9 * (1.0 + pose.r_w_wb.norm()) &&
               (p.C_w_b - pose.C_w_b).norm() <= 1e-9;
      }
      if (same) continue;
      (*poses)[static_cast<std::size_t>(count)] = pose;
      if (depths != nullptr) (*depths)[static_cast<std::size_t>(count)] = s;
      ++count;
    }
  }
  return count;
}

}  // namespace mfns::fw::scan_reference
