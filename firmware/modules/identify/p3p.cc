#include "firmware/modules/identify/p3p.h"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>

namespace mfns::fw {

BodyRay RayOfBlob(const Rig& rig, const BlobObs& blob) {
  const RigCamera& cam = rig.cameras[static_cast<std::size_t>(blob.camera)];
  BodyRay ray;
  ray.o_b = cam.r_b_bk;
  ray.d_b = (cam.C_k_b.transpose() * Eigen::Vector3d(blob.x_n.x(), blob.x_n.y(), 1.0)).normalized();
  return ray;
}

bool P3pOptions::IsValid(const char** why) const {
  const char* bad = nullptr;
  if (!(min_depth_m > 0.0) || !std::isfinite(min_depth_m)) bad = "min_depth_m";
  else if (!(max_depth_m > min_depth_m) || !std::isfinite(max_depth_m)) bad = "max_depth_m";
  else if (scan_steps < 8 || scan_steps > limits::kMaxP3pScanSteps) bad = "scan_steps";
  else if (!(near_double_residual >= 0.0) || !(near_double_residual < 1.0)) bad = "near_double_residual";
  if (why != nullptr) *why = bad != nullptr ? bad : "ok";
  return bad == nullptr;
}

bool P3pRayTriple::Set(const std::array<BodyRay, 3>& rays, const P3pOptions& options) {
  valid_ = false;
  if (!options.IsValid()) return false;
  rays_ = rays;
  options_ = options;
  // Along ray 1 at depth l, with u_k = o1 - o_k: m_k(l) = d_k . (P1 - o_k) = a_k + b_k l and
  // |P1 - o_k|^2 = c_k + 2 e_k l + l^2.
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
  // One camera: the central closed form.
  const double scale = 1.0 + rays[0].o_b.norm();
  central_ = (rays[1].o_b - rays[0].o_b).norm() <= 1e-12 * scale && (rays[2].o_b - rays[0].o_b).norm() <= 1e-12 * scale;
  cos_a_ = rays[1].d_b.dot(rays[2].d_b);
  cos_b_ = rays[0].d_b.dot(rays[2].d_b);
  cos_c_ = rays[0].d_b.dot(rays[1].d_b);
  valid_ = true;
  return true;
}

namespace {

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

}  // namespace

int P3pRayTriple::Solve(const std::array<Eigen::Vector3d, 3>& P_w,
                        std::array<BodyPose, limits::kMaxP3pSolutions>* poses,
                        std::array<Eigen::Vector3d, limits::kMaxP3pSolutions>* depths) const {
  if (!valid_) return 0;
  return central_ ? SolveCentral(P_w, poses, depths) : SolveGeneral(P_w, poses, depths);
}

namespace {

// Product of polynomials a (degree na) and b (degree nb), coefficients lowest first.
template <std::size_t kOut>
void PolyMul(const double* a, int na, const double* b, int nb, std::array<double, kOut>* out) {
  out->fill(0.0);
  for (int i = 0; i <= na; ++i)
    for (int j = 0; j <= nb; ++j) (*out)[static_cast<std::size_t>(i + j)] += a[i] * b[j];
}

// Value and derivative of c[0] + ... + c[n] x^n at x (Horner).
double Horner(const double* c, int n, double x, double* derivative) {
  double p = c[n], dp = 0.0;
  for (int i = n - 1; i >= 0; --i) {
    dp = dp * x + p;
    p = p * x + c[i];
  }
  *derivative = dp;
  return p;
}


// The root of c (degree n) in [a, b] where f(a) = fa and f(b) = fb have opposite signs:
// Newton from the secant point, kept inside the shrinking bracket (bisection otherwise), until
// a step or the bracket is below rel_tol (relative to max(1, |x|)).
double BracketedRoot(const double* c, int n, double a, double b, double fa, double fb, double rel_tol) {
  double x = a - fa * (b - a) / (fb - fa);
  if (!(x > a && x < b)) x = 0.5 * (a + b);
  const bool rising = fa < 0.0;
  double d = 0.0;
  for (int it = 0; it < limits::kMaxBisectionIterations; ++it) {
    const double f = Horner(c, n, x, &d);
    if (f == 0.0) break;
    if ((f < 0.0) == rising) a = x;
    else b = x;
    double next = x - f / d;
    if (!(next > a && next < b)) next = 0.5 * (a + b);
    const double tol = rel_tol * std::max(1.0, std::abs(x));
    const bool done = std::abs(next - x) <= tol || b - a <= tol;
    x = next;
    if (done) break;
  }
  return x;
}

}  // namespace

int PolynomialRealRoots(const double* c, int n, double* roots) {
  while (n > 0 && c[n] == 0.0) --n;
  if (n <= 0 || n > 4) return 0;
  if (n == 1) {
    roots[0] = -c[0] / c[1];
    return 1;
  }
  if (n == 2) {
    double x0 = 0.0, x1 = 0.0;
    const int k = Quadratic(c[2], c[1], c[0], &x0, &x1);
    if (k == 0) return 0;
    if (x0 > x1) std::swap(x0, x1);
    roots[0] = x0;
    if (k == 1 || x1 == x0) return 1;
    roots[1] = x1;
    return 2;
  }
  // Fujiwara's bound on |root|: 2 max |c[n-k] / c[n]|^(1/k), the last term halved (far
  // tighter than Cauchy's, so the outer stretches need fewer safeguarded steps).
  double bound = 0.0;
  for (int k = 1; k <= n; ++k) {
    const double r = std::abs(c[n - k] / c[n]) * (k == n ? 0.5 : 1.0);
    bound = std::max(bound, k == 1 ? r : std::pow(r, 1.0 / k));
  }
  bound = 2.0 * bound * (1.0 + 1e-12) + 1e-300;
  std::array<double, 4> dc{};
  for (int i = 1; i <= n; ++i) dc[static_cast<std::size_t>(i - 1)] = i * c[i];
  std::array<double, 5> pts{};
  int np = 0;
  pts[static_cast<std::size_t>(np++)] = -bound;
  std::array<double, 3> crit{};
  const int nc = PolynomialRealRoots(dc.data(), n - 1, crit.data());
  for (int i = 0; i < nc; ++i)
    if (crit[static_cast<std::size_t>(i)] > -bound && crit[static_cast<std::size_t>(i)] < bound)
      pts[static_cast<std::size_t>(np++)] = crit[static_cast<std::size_t>(i)];
  pts[static_cast<std::size_t>(np++)] = bound;
  int count = 0;
  auto add = [&](double x) {
    if (count > 0 && std::abs(roots[count - 1] - x) <= 1e-12 * std::max(1.0, std::abs(x))) return;
    roots[count++] = x;
  };
  for (int i = 0; i + 1 < np; ++i) {
    double a = pts[static_cast<std::size_t>(i)], b = pts[static_cast<std::size_t>(i + 1)], d = 0.0;
    const double fa = Horner(c, n, a, &d), fb = Horner(c, n, b, &d);
    // A critical point on zero (within rounding of the terms): a double root.
    double mag = 0.0;
    for (int k = n; k >= 0; --k) mag = mag * std::abs(a) + std::abs(c[k]);
    if (i > 0 && std::abs(fa) <= 1e-13 * mag) {
      add(a);
      continue;
    }
    if ((fa < 0.0) == (fb < 0.0) || fb == 0.0) continue;
    // (Near the root the rounding of f makes Newton jitter by more than an ulp: stop at 1e-13;
    // the P3P polishes its depths on the distance equations afterwards.)
    add(BracketedRoot(c, n, a, b, fa, fb, 1e-13));
  }
  return count;
}

namespace {

// Bernstein roots are bracketed to 1e-11: the callers polish on their own equations afterwards.
constexpr double kRootTol = 1e-11;

// Sign changes in b[0..n], zeros skipped, counted up to 2 (Descartes' rule for the Bernstein
// form: at least the number of roots in the open interval, with the same parity; 0 or 1
// exactly, and the callers only tell 0, 1 and more apart).
int SignVariations(const double* b, int n) {
  int v = 0;
  double prev = 0.0;
  for (int i = 0; i <= n; ++i) {
    if (b[i] == 0.0) continue;
    if (prev != 0.0 && (b[i] < 0.0) != (prev < 0.0) && ++v == 2) break;
    prev = b[i];
  }
  return v;
}


}  // namespace

namespace {

// PolynomialRealRootsIn for degree kN (0: the degree n at run time). The fixed degree lets
// the compiler unroll the short loops of the P3P's octic.
template <int kN>
int RealRootsInImpl(const double* c, int n_runtime, double lo, double hi, double* roots) {
  const int n = kN > 0 ? kN : n_runtime;
  // q(t) = p(lo + h t) on t in [0, 1]: a Taylor shift (repeated synthetic division), then the
  // scaling of t.
  const double h = hi - lo;
  std::array<double, 9> q{};
  for (int i = 0; i <= n; ++i) q[static_cast<std::size_t>(i)] = c[i];
  for (int i = 0; i < n; ++i)
    for (int k = n - 1; k >= i; --k) q[static_cast<std::size_t>(k)] += lo * q[static_cast<std::size_t>(k + 1)];
  double hk = 1.0;
  for (int k = 1; k <= n; ++k) q[static_cast<std::size_t>(k)] *= (hk *= h);
  // Bernstein coefficients: b_i = sum_k C(i, k) / C(n, k) q_k.
  static constexpr std::array<std::array<double, 9>, 9> kBinomial = {{
      {1, 0, 0, 0, 0, 0, 0, 0, 0},       {1, 1, 0, 0, 0, 0, 0, 0, 0},        {1, 2, 1, 0, 0, 0, 0, 0, 0},
      {1, 3, 3, 1, 0, 0, 0, 0, 0},       {1, 4, 6, 4, 1, 0, 0, 0, 0},        {1, 5, 10, 10, 5, 1, 0, 0, 0},
      {1, 6, 15, 20, 15, 6, 1, 0, 0},    {1, 7, 21, 35, 35, 21, 7, 1, 0},    {1, 8, 28, 56, 70, 56, 28, 8, 1}}};
  const auto sn = static_cast<std::size_t>(n);
  for (std::size_t k = 1; k < sn; ++k) q[k] /= kBinomial[sn][k];  // (q_k / C(n, k) once)
  struct Node {
    std::array<double, 9> b;
    double a, w;
    int depth;
  };
  // Depth-first, left child first (ascending roots); one pending sibling per level.
  constexpr int kMaxDepth = 40;  // 2^-40 of the interval: far below the 1e-7 cluster width
  constexpr int kMaxNodes = 2 * 8 * (kMaxDepth + 1);
  std::array<Node, kMaxDepth + 2> stack;
  int top = 0;
  Node& root = stack[0];
  for (std::size_t i = 0; i <= sn; ++i) {
    double s = 0.0;
    for (std::size_t k = 0; k <= i; ++k) s += kBinomial[i][k] * q[k];
    root.b[i] = s;
  }
  root.a = lo;
  root.w = h;
  root.depth = 0;
  top = 1;
  int count = 0;
  if (root.b[0] == 0.0) roots[count++] = lo;
  // Pieces are not split below 1e-7 of the interval: where rounding makes the sign changes
  // meaningless (near a multiple root) this keeps the pieces few; the callers polish every
  // candidate on their own equations.
  const double min_width = 1e-7 * h;

  // Each node either ends or splits into two narrower ones, at most kMaxDepth deep. A node
  // splits only while it may hold two or more roots or an extremum near zero; the children
  // of a node share its sign variations, so few nodes per level split. kMaxNodes bounds the
  // loop (far above what a degree-8 polynomial needs: each root or cluster costs at most two
  // nodes per level).
  // A candidate for a double root or a cluster: kept once per place (the one nearer zero when
  // two pieces of one flat stretch both report).
  double last_cluster_value = 0.0;
  bool last_is_cluster = false;
  auto add_cluster = [&](double x) {
    double d = 0.0;
    const double fx = std::abs(Horner(c, n, x, &d));
    if (count > 0 && last_is_cluster && x - roots[count - 1] <= 1e-6 * h) {
      if (fx < last_cluster_value) {
        roots[count - 1] = x;
        last_cluster_value = fx;
      }
      return;
    }
    if (count >= n) return;
    roots[count++] = x;
    last_cluster_value = fx;
    last_is_cluster = true;
  };
  for (int guard = 0; top > 0 && guard < kMaxNodes; ++guard) {
    const Node node = stack[static_cast<std::size_t>(--top)];
    const int v = SignVariations(node.b.data(), n);
    if (v == 1 && node.b[0] != 0.0 && node.b[sn] != 0.0) {  // exactly one root
      if (count < n) {
        roots[count++] = BracketedRoot(c, n, node.a, node.a + node.w, node.b[0], node.b[sn], kRootTol);
        last_is_cluster = false;
      }
      continue;
    }
    // Rounding of the values on the piece: relative to the terms' magnitude there (the
    // coefficients carry the rounding of their own derivation, hence 1e-12 rather than 1e-16).
    const double xm = std::max(std::abs(node.a), std::abs(node.a + node.w));
    double mag = 0.0;
    for (int k = n; k >= 0; --k) mag = mag * xm + std::abs(c[k]);
    double closest = std::abs(node.b[0]), largest = closest;
    for (std::size_t i = 1; i <= sn; ++i) {
      closest = std::min(closest, std::abs(node.b[i]));
      largest = std::max(largest, std::abs(node.b[i]));
    }
    if (largest <= 1e-14 * mag) {
      // The whole piece is within rounding of zero (a root of multiplicity two or more seen
      // through noise, whose sign changes mean nothing): one candidate.
      add_cluster(node.a + 0.5 * node.w);
      continue;
    }
    if (v == 0) {
      // No root here, unless the polynomial comes within rounding of zero (a double root may
      // touch zero without crossing it once its coefficients are rounded): the Bernstein
      // coefficients bound the polynomial on the piece, so it is that close only if one is.
      if (closest > 1e-12 * mag) continue;
      // Then its extremum: where the derivative's Bernstein coefficients (differences of
      // these) change sign once, found on the derivative; monotone: none here.
      std::array<double, 8> db{};
      for (std::size_t i = 0; i < sn; ++i) db[i] = node.b[i + 1] - node.b[i];
      const int dv = SignVariations(db.data(), n - 1);
      if (dv == 0) continue;
      if (dv == 1 && db[0] != 0.0 && db[sn - 1] != 0.0) {
        std::array<double, 8> dc{};
        for (int k = 1; k <= n; ++k) dc[static_cast<std::size_t>(k - 1)] = k * c[k];
        const double x = BracketedRoot(dc.data(), n - 1, node.a, node.a + node.w, db[0], db[sn - 1], kRootTol);
        double d = 0.0;
        if (std::abs(Horner(c, n, x, &d)) <= 1e-12 * mag) add_cluster(x);
        continue;
      }
    }
    if (node.w <= min_width || node.depth >= kMaxDepth) {
      // Roots closer than the width (or an extremum too flat to place): one candidate; the
      // callers check it on their own equations.
      add_cluster(node.a + 0.5 * node.w);
      continue;
    }
    // de Casteljau at t = 1/2: the left child's coefficients are the first of each level, the
    // right child's the last.
    Node left, right;
    std::array<double, 9> t = node.b;
    left.b[0] = t[0];
    right.b[sn] = t[sn];
    for (std::size_t r = 1; r <= sn; ++r) {
      for (std::size_t i = 0; i + r <= sn; ++i) t[i] = 0.5 * (t[i] + t[i + 1]);
      left.b[r] = t[0];
      right.b[sn - r] = t[sn - r];
    }
    left.a = node.a;
    right.a = node.a + 0.5 * node.w;
    left.w = right.w = 0.5 * node.w;
    left.depth = right.depth = node.depth + 1;
    // A root exactly at the split point: the children's variations skip zeros, so report it
    // here (out of order: sorted below).
    if (left.b[sn] == 0.0 && count < n) {
      roots[count++] = right.a;
      last_is_cluster = false;
    }
    stack[static_cast<std::size_t>(top++)] = right;
    stack[static_cast<std::size_t>(top++)] = left;
  }
  std::sort(roots, roots + count);
  return count;
}

}  // namespace

int PolynomialRealRootsIn(const double* c, int n, double lo, double hi, double* roots) {
  while (n > 0 && c[n] == 0.0) --n;
  if (n <= 0 || n > 8 || !(lo < hi) || !std::isfinite(hi - lo)) return 0;
  return n == 8 ? RealRootsInImpl<8>(c, 8, lo, hi, roots) : RealRootsInImpl<0>(c, n, lo, hi, roots);
}

namespace {

// Orthonormal frame of a triangle: x along p1 - p0, z its normal. False when (nearly) collinear.
bool TriangleFrame(const std::array<Eigen::Vector3d, 3>& p, Eigen::Matrix3d* F) {
  const Eigen::Vector3d e1 = p[1] - p[0], x2 = p[2] - p[0];
  const Eigen::Vector3d e3 = e1.cross(x2);
  const double n1 = e1.norm(), n3 = e3.norm();
  if (!(n1 > 0.0) || !(n3 > 1e-9 * n1 * x2.norm())) return false;
  F->col(0) = e1 / n1;
  F->col(2) = e3 / n3;
  F->col(1) = F->col(2).cross(F->col(0));
  return F->allFinite();
}

// The world triangle's frame and centroid, computed once per Solve for all its solutions.
struct WorldTriangle {
  Eigen::Matrix3d F;
  Eigen::Vector3d centroid;
  bool ok = false;
};

WorldTriangle MakeWorldTriangle(const std::array<Eigen::Vector3d, 3>& P_w) {
  WorldTriangle w;
  w.ok = TriangleFrame(P_w, &w.F);
  w.centroid = (P_w[0] + P_w[1] + P_w[2]) / 3.0;
  return w;
}

// TriangleOrientation with the world side precomputed.
bool PoseFromBodyPoints(const WorldTriangle& w, const std::array<Eigen::Vector3d, 3>& q_b, BodyPose* pose) {
  Eigen::Matrix3d Fb;
  if (!w.ok || !TriangleFrame(q_b, &Fb)) return false;
  pose->C_w_b = w.F * Fb.transpose();
  pose->r_w_wb = w.centroid - pose->C_w_b * ((q_b[0] + q_b[1] + q_b[2]) / 3.0);
  return pose->C_w_b.allFinite() && pose->r_w_wb.allFinite();
}

// The three distance equations of depths l along the rays, in the scalars of P3pRayTriple:
// with u = o1 - o_k, |o1 + l1 d1 - o_k - lk dk|^2 = c + l1^2 + lk^2 + 2 e l1 - 2 a lk - 2 b l1 lk
// (a = dk.u, b = d1.dk, c = |u|^2, e = d1.u), and the same for rays 2 and 3 with o23 = o2 - o3.
// (One camera: a = c = e = 0 and o23 = 0, the law of cosines.)
struct DepthEquations {
  double a2, b2, c2, e2;      // ray 2 against ray 1
  double a3, b3, c3, e3;      // ray 3 against ray 1
  double o23_sq, d2_o23, d3_o23, d23;
  double D12, D13, D23;       // squared beacon distances

  // Largest residual relative to its squared distance.
  double Residuals(const Eigen::Vector3d& l, Eigen::Vector3d* r) const {
    const double l1 = l(0), l2 = l(1), l3 = l(2);
    (*r)(0) = c2 + l1 * l1 + l2 * l2 + 2.0 * (e2 * l1 - a2 * l2 - b2 * l1 * l2) - D12;
    (*r)(1) = c3 + l1 * l1 + l3 * l3 + 2.0 * (e3 * l1 - a3 * l3 - b3 * l1 * l3) - D13;
    (*r)(2) = o23_sq + l2 * l2 + l3 * l3 + 2.0 * (d2_o23 * l2 - d3_o23 * l3 - d23 * l2 * l3) - D23;
    return std::max(std::max(std::abs((*r)(0)) / D12, std::abs((*r)(1)) / D13), std::abs((*r)(2)) / D23);
  }

  // Where two solutions nearly merge, the other one (the "twin") from a solution l: J is
  // nearly singular with right and left null vectors v and u (a column and a row of its
  // adjugate, which is ~ sigma_1 sigma_2 v u^T); the equations are exactly quadratic, so along
  // l + t v the residual is r + t J v + t^2 q(v) (q: each equation's quadratic part), and its
  // component along u vanishes again at t = -u.Jv / u.q(v). False when that is not a near
  // twin (more than 5 % of the depths away: an isolated solution's J is far from singular and
  // t large); the caller polishes and checks it. (Cheaper and surer than judging from det J
  // how close the twin is.)
  bool Twin(const Eigen::Vector3d& l, Eigen::Vector3d* twin) const {
    const double l1 = l(0), l2 = l(1), l3 = l(2);
    const double j11 = l1 + e2 - b2 * l2, j12 = l2 - a2 - b2 * l1;
    const double j21 = l1 + e3 - b3 * l3, j23 = l3 - a3 - b3 * l1;
    const double j32 = l2 + d2_o23 - d23 * l3, j33 = l3 - d3_o23 - d23 * l2;
    Eigen::Matrix3d J;  // (half the Jacobian: the factor 2 cancels in t)
    J << j11, j12, 0.0, j21, 0.0, j23, 0.0, j32, j33;
    Eigen::Matrix3d adj;  // adjugate = transposed cofactors
    adj << -j23 * j32, -j12 * j33, j12 * j23,  //
        -j21 * j33, j11 * j33, -j11 * j23,      //
        j21 * j32, -j11 * j32, -j12 * j21;
    Eigen::Index col = 0, row = 0;
    adj.colwise().squaredNorm().maxCoeff(&col);
    adj.rowwise().squaredNorm().maxCoeff(&row);
    const Eigen::Vector3d v = adj.col(col).normalized(), u = adj.row(row).transpose().normalized();
    if (!v.allFinite() || !u.allFinite()) return false;
    const Eigen::Vector3d q(v(0) * v(0) + v(1) * v(1) - 2.0 * b2 * v(0) * v(1),
                            v(0) * v(0) + v(2) * v(2) - 2.0 * b3 * v(0) * v(2),
                            v(1) * v(1) + v(2) * v(2) - 2.0 * d23 * v(1) * v(2));
    const double uq = u.dot(q), uJv = 2.0 * u.dot(J * v);
    if (uq == 0.0) return false;
    const double t = -uJv / uq;
    if (!(std::abs(t) <= 0.05 * l.norm())) return false;
    *twin = l + t * v;
    return true;
  }

  // Newton steps on the three equations, each kept only if it lowers the largest relative
  // residual (near a double root the Jacobian is nearly singular and a step may overshoot);
  // returns that residual.
  double Polish(Eigen::Vector3d* l) const {
    Eigen::Vector3d r;
    double err = Residuals(*l, &r);
    // (Usually two steps; up to 16 from near a double root, or from a root of the octic near a
    // branch end, which its squarings determine to a few digits only.)
    for (int it = 0; it < 16 && err > 1e-15; ++it) {
      const double l1 = (*l)(0), l2 = (*l)(1), l3 = (*l)(2);
      // Jacobian [[j11 j12 0] [j21 0 j23] [0 j32 j33]], inverted by its cofactors.
      const double j11 = 2.0 * (l1 + e2 - b2 * l2), j12 = 2.0 * (l2 - a2 - b2 * l1);
      const double j21 = 2.0 * (l1 + e3 - b3 * l3), j23 = 2.0 * (l3 - a3 - b3 * l1);
      const double j32 = 2.0 * (l2 + d2_o23 - d23 * l3), j33 = 2.0 * (l3 - d3_o23 - d23 * l2);
      const double det = -j11 * j23 * j32 - j12 * j21 * j33;
      if (det == 0.0) break;
      const double inv = 1.0 / det;
      const Eigen::Vector3d step(inv * (-j23 * j32 * r(0) - j12 * j33 * r(1) + j12 * j23 * r(2)),
                                 inv * (-j21 * j33 * r(0) + j11 * j33 * r(1) - j11 * j23 * r(2)),
                                 inv * (j21 * j32 * r(0) - j11 * j32 * r(1) - j12 * j21 * r(2)));
      // Near a double root the full step overshoots (the residual is quadratic there): halve
      // it until the residual drops (Newton then converges linearly, not quadratically).
      Eigen::Vector3d trial = *l - step, r_trial;
      double err_trial = Residuals(trial, &r_trial);
      double scale = 1.0;
      for (int h = 0; h < 4 && !(err_trial < err); ++h) {
        scale *= 0.5;
        trial = *l - scale * step;
        err_trial = Residuals(trial, &r_trial);
      }
      if (!(err_trial < err)) break;
      *l = trial;
      r = r_trial;
      err = err_trial;
    }
    return err;
  }
};

// Solutions of a P3P are accepted when the polished depths satisfy every distance to this
// (relative to the squared distance; the same as the closed form of session 6).
constexpr double kAcceptResidual = 1e-9;
// A complex pair of roots is looked at (P3pOptions::near_double_residual) only when its
// discriminant is this small against its terms: far from merging, the pair's real part
// satisfies no distance equation and would cost a Polish for nothing.
constexpr double kNearTangent = 1e-2;

// The collected solutions of one Solve: depth filter, duplicates, pose.
class SolutionSink {
 public:
  SolutionSink(const std::array<BodyRay, 3>& rays, const P3pOptions& o, const std::array<Eigen::Vector3d, 3>& P_w,
               std::array<BodyPose, limits::kMaxP3pSolutions>* poses,
               std::array<Eigen::Vector3d, limits::kMaxP3pSolutions>* depths)
      : rays_(rays), o_(o), world_(MakeWorldTriangle(P_w)), poses_(poses), depths_(depths) {}

  // Depths l (polished, residual checked): kept when l1 in [min, max] and l2, l3 >= min (the
  // contract of the scan before), not a duplicate and the body triangle not degenerate.
  void Add(const Eigen::Vector3d& l) {
    if (count_ >= limits::kMaxP3pSolutions || !l.allFinite()) return;
    if (l(0) < o_.min_depth_m || l(0) > o_.max_depth_m || l(1) < o_.min_depth_m || l(2) < o_.min_depth_m) return;
    for (int i = 0; i < count_; ++i)  // one solution reached from two candidates
      if ((kept_[static_cast<std::size_t>(i)] - l).cwiseAbs().maxCoeff() <= 1e-9 * l.maxCoeff()) return;
    const std::array<Eigen::Vector3d, 3> q = {rays_[0].o_b + l(0) * rays_[0].d_b, rays_[1].o_b + l(1) * rays_[1].d_b,
                                              rays_[2].o_b + l(2) * rays_[2].d_b};
    BodyPose pose;
    if (!PoseFromBodyPoints(world_, q, &pose)) return;
    (*poses_)[static_cast<std::size_t>(count_)] = pose;
    if (depths_ != nullptr) (*depths_)[static_cast<std::size_t>(count_)] = l;
    kept_[static_cast<std::size_t>(count_)] = l;
    ++count_;
  }
  int count() const { return count_; }

 private:
  const std::array<BodyRay, 3>& rays_;
  const P3pOptions& o_;
  WorldTriangle world_;
  std::array<BodyPose, limits::kMaxP3pSolutions>* poses_;
  std::array<Eigen::Vector3d, limits::kMaxP3pSolutions>* depths_;
  std::array<Eigen::Vector3d, limits::kMaxP3pSolutions> kept_{};
  int count_ = 0;
};

// Cofactor matrix (= adjugate, symmetric input) of a symmetric 3 x 3.
Eigen::Matrix3d SymmetricAdjugate(const Eigen::Matrix3d& M) {
  Eigen::Matrix3d A;
  A(0, 0) = M(1, 1) * M(2, 2) - M(1, 2) * M(1, 2);
  A(1, 1) = M(0, 0) * M(2, 2) - M(0, 2) * M(0, 2);
  A(2, 2) = M(0, 0) * M(1, 1) - M(0, 1) * M(0, 1);
  A(0, 1) = A(1, 0) = M(0, 2) * M(1, 2) - M(0, 1) * M(2, 2);
  A(0, 2) = A(2, 0) = M(0, 1) * M(1, 2) - M(0, 2) * M(1, 1);
  A(1, 2) = A(2, 1) = M(0, 1) * M(0, 2) - M(0, 0) * M(1, 2);
  return A;
}

// A real root of x^3 + k2 x^2 + k1 x + k0 (there always is one). With three real roots, the
// one farthest from the other two (largest |derivative|): where two roots nearly merge, the
// degenerate conics they give are ill-determined, the isolated one is not (two P3P solutions
// merging make two roots of the cubic merge, see SolveCentral). Cardano, then Newton steps.
double CubicRoot(double k2, double k1, double k0) {
  const double shift = k2 / 3.0;
  const double p = k1 - k2 * shift;                                // depressed: t^3 + p t + q
  const double q = k0 - k1 * shift + 2.0 * shift * shift * shift;  // x = t - k2/3
  const double half_q = 0.5 * q, third_p = p / 3.0;
  const double disc = half_q * half_q + third_p * third_p * third_p;
  double t = 0.0;
  if (disc >= 0.0) {
    // One real root (or a multiple one): the sum of the two cube roots, without cancellation.
    const double u = -std::copysign(std::cbrt(std::abs(half_q) + std::sqrt(disc)), half_q);
    t = u != 0.0 ? u - third_p / u : 0.0;
  } else {
    // Three real roots t_k = 2 sqrt(-p/3) cos(phi/3 - 2 pi k/3).
    constexpr double kTwoPiThirds = 2.0943951023931957;
    const double r = std::sqrt(-third_p);
    const double phi = std::acos(std::clamp(-half_q / (r * r * r), -1.0, 1.0)) / 3.0;
    double best = 0.0;
    for (int k = 0; k < 3; ++k) {
      const double tk = 2.0 * r * std::cos(phi - kTwoPiThirds * k);
      const double slope = std::abs(3.0 * tk * tk + p);
      if (k == 0 || slope > best) {
        best = slope;
        t = tk;
      }
    }
  }
  double x = t - shift;
  for (int it = 0; it < 2; ++it) {  // Cardano loses digits when the terms cancel
    const double f = ((x + k2) * x + k1) * x + k0, df = (3.0 * x + 2.0 * k2) * x + k1;
    if (df == 0.0) break;
    const double next = x - f / df;
    if (!std::isfinite(next)) break;
    x = next;
  }
  return x;
}

// Lines l and m with D = l m^T + m l^T for a degenerate symmetric D (rank 2: two real lines;
// rank 1: a double line). False when the lines are complex (their one real point is no base
// point of the pencil unless two solutions coincide, which the caller's isolated root avoids).
bool SplitLinePair(const Eigen::Matrix3d& D, Eigen::Vector3d* l, Eigen::Vector3d* m) {
  const Eigen::Matrix3d A = SymmetricAdjugate(D);  // = -(l x m)(l x m)^T
  int i = 0;
  if (-A(1, 1) > -A(i, i)) i = 1;
  if (-A(2, 2) > -A(i, i)) i = 2;
  const double scale = D.cwiseAbs().maxCoeff();
  if (!(scale > 0.0) || !std::isfinite(scale)) return false;
  if (-A(i, i) > 1e-12 * scale * scale) {
    // D + [w]x with w = -+ l x m is 2 l m^T or 2 m l^T: its largest entry's row and column.
    const Eigen::Vector3d w = A.col(i) / std::sqrt(-A(i, i));
    Eigen::Matrix3d R = D;
    R(0, 1) -= w(2);
    R(0, 2) += w(1);
    R(1, 2) -= w(0);
    R(1, 0) += w(2);
    R(2, 0) -= w(1);
    R(2, 1) += w(0);
    Eigen::Index r = 0, c = 0;
    R.cwiseAbs().maxCoeff(&r, &c);
    *l = R.row(r).transpose();
    *m = R.col(c);
    return true;
  }
  if (A.cwiseAbs().maxCoeff() <= 1e-10 * scale * scale) {
    // Rank 1: D = +-l l^T, a double line.
    Eigen::Index j = 0;
    D.diagonal().cwiseAbs().maxCoeff(&j);
    *l = *m = D.col(j);
    return true;
  }
  return false;
}

}  // namespace

// Central P3P (one camera). Depths l along unit rays y_i with cosines c01, c02, c12 and squared
// distances a01, a02, a12: l_i^2 + l_j^2 - 2 c_ij l_i l_j = a_ij, three quadratic forms F_ij(l).
// With the longest side r and the other two i, j, the homogeneous conics
// M1 = F_i - (a_i / a_r) F_r and M2 = F_j - (a_j / a_r) F_r (each distance against the longest,
// so that neither conic degenerates when a side is short) meet in the direction of every
// solution (up to four base points). A real degenerate member M(s) = M_lead + s M_other
// (det = 0, a cubic in s; the member of larger determinant leads so the cubic stays monic
// without overflow) is a pair of lines through the base points; each line meets M_lead in two
// directions (a homogeneous quadratic); the scale comes from the distances. A line tangent to
// the conic (discriminant zero within rounding) is a double root, kept: the tracker needs to
// see the twin of a pose near the danger cylinder.
int P3pRayTriple::SolveCentral(const std::array<Eigen::Vector3d, 3>& P_w,
                               std::array<BodyPose, limits::kMaxP3pSolutions>* poses,
                               std::array<Eigen::Vector3d, limits::kMaxP3pSolutions>* depths) const {
  const double a12 = (P_w[2] - P_w[1]).squaredNorm(), a02 = (P_w[2] - P_w[0]).squaredNorm();
  const double a01 = (P_w[1] - P_w[0]).squaredNorm();
  if (!(a01 > 0.0) || !(a02 > 0.0) || !(a12 > 0.0) || !std::isfinite(a01 + a02 + a12)) return 0;
  const double c01 = cos_c_, c02 = cos_b_, c12 = cos_a_;
  // The quadratic forms of the three pairs.
  std::array<Eigen::Matrix3d, 3> F;
  F[0] << 1.0, -c01, 0.0, -c01, 1.0, 0.0, 0.0, 0.0, 0.0;  // (0,1)
  F[1] << 1.0, 0.0, -c02, 0.0, 0.0, 0.0, -c02, 0.0, 1.0;  // (0,2)
  F[2] << 0.0, 0.0, 0.0, 0.0, 1.0, -c12, 0.0, -c12, 1.0;  // (1,2)
  const std::array<double, 3> a = {a01, a02, a12};
  int r = 0;
  if (a[1] > a[static_cast<std::size_t>(r)]) r = 1;
  if (a[2] > a[static_cast<std::size_t>(r)]) r = 2;
  const auto sr = static_cast<std::size_t>(r);
  const auto si = static_cast<std::size_t>((r + 1) % 3), sj = static_cast<std::size_t>((r + 2) % 3);
  Eigen::Matrix3d M1 = F[si] - (a[si] / a[sr]) * F[sr];
  Eigen::Matrix3d M2 = F[sj] - (a[sj] / a[sr]) * F[sr];
  // det(A + s B) = det A + s tr(adj(A) B) + s^2 tr(adj(B) A) + s^3 det B.
  const Eigen::Matrix3d adj1 = SymmetricAdjugate(M1), adj2 = SymmetricAdjugate(M2);
  const double det1 = M1.row(0).dot(adj1.col(0)), det2 = M2.row(0).dot(adj2.col(0));
  const bool two_leads = std::abs(det2) >= std::abs(det1);
  const Eigen::Matrix3d& lead = two_leads ? M2 : M1;
  const Eigen::Matrix3d& other = two_leads ? M1 : M2;
  const Eigen::Matrix3d& adj_lead = two_leads ? adj2 : adj1;
  const Eigen::Matrix3d& adj_other = two_leads ? adj1 : adj2;
  const double det_lead = two_leads ? det2 : det1, det_other = two_leads ? det1 : det2;
  if (det_lead == 0.0) return 0;  // both conics degenerate: the rays or beacons are degenerate
  // Monic in s for other + s lead: s^3 + k2 s^2 + k1 s + k0 (|k0| <= 1).
  const double inv = 1.0 / det_lead;
  const double k2 = adj_lead.cwiseProduct(other).sum() * inv;
  const double k1 = adj_other.cwiseProduct(lead).sum() * inv;
  const double k0 = det_other * inv;
  const double s = CubicRoot(k2, k1, k0);
  const Eigen::Matrix3d D = other + s * lead;

  Eigen::Vector3d lines[2];
  if (!SplitLinePair(D, &lines[0], &lines[1])) return 0;
  const DepthEquations eq{0.0, c01, 0.0, 0.0, 0.0, c02, 0.0, 0.0, 0.0, 0.0, 0.0, c12, a01, a02, a12};
  const double sum_a = a01 + a02 + a12;
  SolutionSink sink(rays_, options_, P_w, poses, depths);
  for (int li = 0; li < (lines[0] == lines[1] ? 1 : 2); ++li) {
    const Eigen::Vector3d& p = lines[li];
    // On the line p . l = 0: l_k from the other two (k the largest |p_k|), l = T mu.
    Eigen::Index k = 0;
    p.cwiseAbs().maxCoeff(&k);
    if (p(k) == 0.0) continue;
    const int i = (static_cast<int>(k) + 1) % 3, j = (static_cast<int>(k) + 2) % 3;
    Eigen::Matrix<double, 3, 2> T = Eigen::Matrix<double, 3, 2>::Zero();
    T(i, 0) = 1.0;
    T(j, 1) = 1.0;
    T(k, 0) = -p(i) / p(k);
    T(k, 1) = -p(j) / p(k);
    const Eigen::Matrix2d Q = T.transpose() * lead * T;  // alpha mu0^2 + 2 beta mu0 mu1 + gamma mu1^2
    const double alpha = Q(0, 0), beta = Q(0, 1), gamma = Q(1, 1);
    double disc = beta * beta - alpha * gamma;
    bool complex_pair = false;  // kept as its real part (near_double_residual)
    if (disc < 0.0) {
      // Tangent within rounding: a double root (two solutions merging), reported once.
      const double scale = beta * beta + std::abs(alpha * gamma);
      complex_pair = disc < -1e-10 * scale;
      if (complex_pair && !(options_.near_double_residual > 0.0 && disc >= -kNearTangent * scale)) continue;
      disc = 0.0;
    }
    // Homogeneous roots (rr, alpha) and (gamma, rr) without cancellation.
    const double rr = -(beta + std::copysign(std::sqrt(disc), beta));
    Eigen::Vector2d mus[2] = {Eigen::Vector2d(rr, alpha), Eigen::Vector2d(gamma, rr)};
    if (rr == 0.0) {  // beta = 0 = disc, so alpha gamma = 0: the root is an axis
      mus[0] = alpha == 0.0 ? Eigen::Vector2d(1.0, 0.0) : Eigen::Vector2d(0.0, 1.0);
      mus[1] = mus[0];
    }
    for (int h = 0; h < (disc > 0.0 ? 2 : 1); ++h) {
      Eigen::Vector3d l = T * mus[h];
      // Scale from the sum of the three distance equations (a positive definite form).
      const double form = 2.0 * l.squaredNorm() - 2.0 * (c01 * l(0) * l(1) + c02 * l(0) * l(2) + c12 * l(1) * l(2));
      if (!(form > 0.0)) continue;
      l *= std::sqrt(sum_a / form);
      if (l.sum() < 0.0) l = -l;
      if (!(l.minCoeff() > 0.0)) continue;
      const double residual = eq.Polish(&l);
      if (residual > (complex_pair ? options_.near_double_residual : kAcceptResidual)) continue;
      sink.Add(l);
      if (complex_pair) continue;
      Eigen::Vector3d twin;  // a tangent line gives one of two merging solutions
      if (eq.Twin(l, &twin) && eq.Polish(&twin) <= kAcceptResidual) sink.Add(twin);
    }
  }
  return sink.count();
}

// Generalized P3P. With l = l_1: l_k = m_k + s_k r_k, r_k = sqrt(g_k), g_k = D_1k^2 - q_k (k = 2, 3;
// m_k, g_k polynomials of degree 1 and 2). The (2,3) residual
//   f = o23^2 + l2^2 + l3^2 + 2 l2 d2.o23 - 2 l3 d3.o23 - 2 d2.d3 l2 l3 - D23^2
//     = A + s2 B r2 + s3 C r3 + s2 s3 E r2 r3
// with A = o23^2 - D23^2 + m2^2 + g2 + m3^2 + g3 + 2 m2 d2.o23 - 2 m3 d3.o23 - 2 d2.d3 m2 m3,
// B = 2 (m2 + d2.o23 - d2.d3 m3), C = 2 (m3 - d3.o23 - d2.d3 m2), E = -2 d2.d3. Moving the r2
// and r3 terms apart and squaring: P + s2 s3 Q r2 r3 = 0 with P = A^2 + E^2 g2 g3 - B^2 g2 - C^2 g3
// and Q = 2 (A E - B C); squaring again: P^2 - Q^2 g2 g3 = 0, an octic in l whose roots hold every
// branch pair's. (The extra roots the squarings admit are refused by the residual test.)
int P3pRayTriple::SolveGeneral(const std::array<Eigen::Vector3d, 3>& P_w,
                               std::array<BodyPose, limits::kMaxP3pSolutions>* poses,
                               std::array<Eigen::Vector3d, limits::kMaxP3pSolutions>* depths) const {
  const double D12 = (P_w[1] - P_w[0]).squaredNorm(), D13 = (P_w[2] - P_w[0]).squaredNorm();
  const double D23 = (P_w[2] - P_w[1]).squaredNorm();
  if (!(D12 > 0.0) || !(D13 > 0.0) || !(D23 > 0.0) || !std::isfinite(D12 + D13 + D23)) return 0;
  const RayCoefficients& R2 = ray2_;
  const RayCoefficients& R3 = ray3_;
  // g_k = D1k^2 - (|P1 - o_k|^2 - m_k^2), lowest coefficient first.
  const double g2[3] = {D12 - R2.c + R2.a * R2.a, 2.0 * (R2.a * R2.b - R2.e), R2.b * R2.b - 1.0};
  const double g3[3] = {D13 - R3.c + R3.a * R3.a, 2.0 * (R3.a * R3.b - R3.e), R3.b * R3.b - 1.0};
  const double m2[2] = {R2.a, R2.b}, m3[2] = {R3.a, R3.b};
  const double w = d2_d3_;
  // m_k^2 + g_k (degree 2).
  const double s2[3] = {m2[0] * m2[0] + g2[0], 2.0 * m2[0] * m2[1] + g2[1], m2[1] * m2[1] + g2[2]};
  const double s3[3] = {m3[0] * m3[0] + g3[0], 2.0 * m3[0] * m3[1] + g3[1], m3[1] * m3[1] + g3[2]};
  const double Ap[3] = {o23_sq_ - D23 + s2[0] + s3[0] + 2.0 * m2[0] * d2_o23_ - 2.0 * m3[0] * d3_o23_ -
                            2.0 * w * m2[0] * m3[0],
                        s2[1] + s3[1] + 2.0 * m2[1] * d2_o23_ - 2.0 * m3[1] * d3_o23_ -
                            2.0 * w * (m2[0] * m3[1] + m2[1] * m3[0]),
                        s2[2] + s3[2] - 2.0 * w * m2[1] * m3[1]};
  const double Bp[2] = {2.0 * (m2[0] + d2_o23_ - w * m3[0]), 2.0 * (m2[1] - w * m3[1])};
  const double Cp[2] = {2.0 * (m3[0] - d3_o23_ - w * m2[0]), 2.0 * (m3[1] - w * m2[1])};
  const double E = -2.0 * w;
  std::array<double, 5> AA{}, g23{}, BBg2{}, CCg3{};
  std::array<double, 3> BB{}, CC{};
  PolyMul(Ap, 2, Ap, 2, &AA);
  PolyMul(g2, 2, g3, 2, &g23);
  PolyMul(Bp, 1, Bp, 1, &BB);
  PolyMul(Cp, 1, Cp, 1, &CC);
  PolyMul(BB.data(), 2, g2, 2, &BBg2);
  PolyMul(CC.data(), 2, g3, 2, &CCg3);
  std::array<double, 5> P{};
  for (std::size_t i = 0; i < 5; ++i) P[i] = AA[i] + E * E * g23[i] - BBg2[i] - CCg3[i];
  std::array<double, 3> BC{};
  PolyMul(Bp, 1, Cp, 1, &BC);
  const double Q[3] = {2.0 * (Ap[0] * E - BC[0]), 2.0 * (Ap[1] * E - BC[1]), 2.0 * (Ap[2] * E - BC[2])};
  std::array<double, 5> QQ{};
  PolyMul(Q, 2, Q, 2, &QQ);
  std::array<double, 9> PP{}, QQg23{}, octic{};
  PolyMul(P.data(), 4, P.data(), 4, &PP);
  PolyMul(QQ.data(), 4, g23.data(), 4, &QQg23);
  for (std::size_t i = 0; i < 9; ++i) octic[i] = PP[i] - QQg23[i];

  std::array<double, 8> l1s{};
  const int n = PolynomialRealRootsIn(octic.data(), 8, options_.min_depth_m, options_.max_depth_m, l1s.data());
  const DepthEquations eq{R2.a, R2.b, R2.c, R2.e, R3.a, R3.b, R3.c, R3.e, o23_sq_, d2_o23_, d3_o23_, w, D12, D13, D23};
  const double scale = D12 + D13 + D23 + o23_sq_;
  SolutionSink sink(rays_, options_, P_w, poses, depths);
  // Branch pair c (bit 0: s2 = +1, bit 1: s3 = +1) at l1: false beyond a branch's end (with
  // `clamp`, a little beyond it counts as at it); else the depths and the (2,3) residual.
  auto branch = [&](double l, int c, bool clamp, Eigen::Vector3d* depth) -> double {
    double q2 = g2[0] + (g2[1] + g2[2] * l) * l, q3 = g3[0] + (g3[1] + g3[2] * l) * l;
    if (q2 < 0.0 || q3 < 0.0) {
      if (!clamp) return std::numeric_limits<double>::quiet_NaN();
      q2 = std::max(0.0, q2);
      q3 = std::max(0.0, q3);
    }
    const double r2 = std::sqrt(q2), r3 = std::sqrt(q3);
    const double l2 = m2[0] + m2[1] * l + ((c & 1) != 0 ? r2 : -r2);
    const double l3 = m3[0] + m3[1] * l + ((c & 2) != 0 ? r3 : -r3);
    *depth = Eigen::Vector3d(l, l2, l3);
    return o23_sq_ + l2 * l2 + l3 * l3 + 2.0 * (l2 * d2_o23_ - l3 * d3_o23_ - w * l2 * l3) - D23;
  };
  // Polishes a start and keeps it when it satisfies the three distances; returns how far l1
  // moved (infinite when refused).
  auto try_depth = [&](Eigen::Vector3d depth) {
    const double start = depth(0);
    if (eq.Polish(&depth) > kAcceptResidual) return std::numeric_limits<double>::infinity();
    sink.Add(depth);
    // A twin within a few percent may lie closer than the octic resolves.
    Eigen::Vector3d twin;
    if (eq.Twin(depth, &twin) && eq.Polish(&twin) <= kAcceptResidual) sink.Add(twin);
    return std::abs(depth(0) - start);
  };
  // Root of branch c's residual between a and b (valid, opposite signs): Illinois.
  auto branch_root = [&](double a, double fa, double b, double fb, int c) {
    Eigen::Vector3d depth;
    int side = 0;
    double x = a;
    for (int it = 0; it < limits::kMaxBisectionIterations; ++it) {
      double next = (a * fb - b * fa) / (fb - fa);
      if (!(next > std::min(a, b) && next < std::max(a, b))) next = 0.5 * (a + b);
      const bool done = std::abs(next - x) <= 1e-13 * std::abs(next);
      x = next;
      const double fx = branch(x, c, true, &depth);
      if (fx == 0.0 || done) break;
      if ((fx < 0.0) == (fb < 0.0)) {
        b = x;
        fb = fx;
        if (side == -1) fa *= 0.5;
        side = -1;
      } else {
        a = x;
        fa = fx;
        if (side == 1) fb *= 0.5;
        side = 1;
      }
    }
    branch(x, c, true, &depth);
    try_depth(depth);
  };
  // Where the octic is poorly conditioned (its two squarings cancel near close roots and branch
  // ends: a root may move by ~1e-4 m or hide), the residuals themselves are searched around the
  // place: each branch pair sampled at kLocalSamples points over +-0.3 % of l1, its sign changes
  // refined, its dips towards zero minimized (golden section) and split at the minimum, its
  // branch ends located; every find polished and checked like the octic's roots.
  constexpr int kLocalSamples = 24;
  auto local_search = [&](double centre) {
    const double half = 3e-3 * centre;
    const double lo = std::max(options_.min_depth_m, centre - half), hi = std::min(options_.max_depth_m, centre + half);
    if (!(lo < hi)) return;
    for (int c = 0; c < 4; ++c) {
      std::array<double, kLocalSamples> xs{}, fs{};
      Eigen::Vector3d depth;
      for (int j = 0; j < kLocalSamples; ++j) {
        xs[static_cast<std::size_t>(j)] = lo + (hi - lo) * j / (kLocalSamples - 1);
        fs[static_cast<std::size_t>(j)] = branch(xs[static_cast<std::size_t>(j)], c, false, &depth);
      }
      for (int j = 1; j < kLocalSamples; ++j) {
        const auto sj = static_cast<std::size_t>(j);
        const double x0 = xs[sj - 1], x1 = xs[sj], f0 = fs[sj - 1], f1 = fs[sj];
        const bool ok0 = !std::isnan(f0), ok1 = !std::isnan(f1);
        if (ok0 && ok1) {
          if ((f0 < 0.0) != (f1 < 0.0)) {
            branch_root(x0, f0, x1, f1, c);
          } else if (j >= 2 && !std::isnan(fs[sj - 2]) && (fs[sj - 2] < 0.0) == (f0 < 0.0) &&
                     std::abs(f0) < std::abs(fs[sj - 2]) && std::abs(f0) < std::abs(f1)) {
            // A dip towards zero between samples j - 2 and j: its minimum of |f|.
            constexpr double kInvPhi = 0.6180339887498949;
            const double sign = f0 < 0.0 ? -1.0 : 1.0;
            double a = xs[sj - 2], b = x1;
            double u = b - kInvPhi * (b - a), v = a + kInvPhi * (b - a);
            double fu = sign * branch(u, c, true, &depth), fv = sign * branch(v, c, true, &depth);
            for (int it = 0; it < limits::kMaxBisectionIterations && fu > 0.0 && fv > 0.0 && b - a > 1e-12 * b; ++it) {
              if (fu < fv) {
                b = v;
                v = u;
                fv = fu;
                u = b - kInvPhi * (b - a);
                fu = sign * branch(u, c, true, &depth);
              } else {
                a = u;
                u = v;
                fu = fv;
                v = a + kInvPhi * (b - a);
                fv = sign * branch(v, c, true, &depth);
              }
            }
            const double xm = fu < fv ? u : v, fm = std::min(fu, fv);
            if (fm <= 0.0) {  // crossed: a root on either side
              branch_root(xs[sj - 2], fs[sj - 2], xm, sign * fm, c);
              branch_root(xm, sign * fm, x1, f1, c);
            } else if (fm <= 1e-12 * scale) {  // touches: a double root
              branch(xm, c, true, &depth);
              try_depth(depth);
            }
          }
        } else if (ok0 != ok1) {
          // A branch end between the samples: bisect on validity, then the end against the
          // valid sample.
          double in = ok0 ? x0 : x1, out = ok0 ? x1 : x0;
          for (int it = 0; it < limits::kMaxBisectionIterations && std::abs(out - in) > 1e-14 * in; ++it) {
            const double mid = 0.5 * (in + out);
            (std::isnan(branch(mid, c, false, &depth)) ? out : in) = mid;
          }
          const double fe = branch(in, c, true, &depth), fin = ok0 ? f0 : f1, xin = ok0 ? x0 : x1;
          if ((fe < 0.0) != (fin < 0.0)) branch_root(std::min(in, xin), in < xin ? fe : fin, std::max(in, xin),
                                                      in < xin ? fin : fe, c);
          else if (std::abs(fe) <= 1e-9 * scale) try_depth(depth);
        }
      }
    }
  };
  // The octic's roots (and clusters): each polished on the branch pairs whose residual nearly
  // vanishes there; where the polish fails or moves l1 by more than 1e-7 (relative), the
  // octic was inaccurate there and the residuals are searched around it (at most
  // kMaxLocalSearches per solve, not twice over one place).
  constexpr int kMaxLocalSearches = 4;
  std::array<double, kMaxLocalSearches> searched{};
  int num_searched = 0;
  for (int i = 0; i < n; ++i) {
    const double l = l1s[static_cast<std::size_t>(i)];
    std::array<double, 4> f{};
    std::array<Eigen::Vector3d, 4> start;
    int best = -1;
    for (int c = 0; c < 4; ++c) {
      // (Beyond a branch's end by up to 1e-3 of the distance: from the end.)
      double q2 = g2[0] + (g2[1] + g2[2] * l) * l, q3 = g3[0] + (g3[1] + g3[2] * l) * l;
      if (q2 < -1e-3 * D12 || q3 < -1e-3 * D13) break;
      f[static_cast<std::size_t>(c)] = std::abs(branch(l, c, true, &start[static_cast<std::size_t>(c)]));
      if (best < 0 || f[static_cast<std::size_t>(c)] < f[static_cast<std::size_t>(best)]) best = c;
    }
    bool inaccurate = best < 0;
    for (int c = 0; c < 4 && best >= 0; ++c) {
      if (c != best && f[static_cast<std::size_t>(c)] > 1e-5 * scale) continue;
      const double moved = try_depth(start[static_cast<std::size_t>(c)]);
      if (c == best && !(moved <= 1e-7 * l)) inaccurate = true;
    }
    if (!inaccurate || num_searched >= kMaxLocalSearches) continue;
    bool seen = false;
    for (int k = 0; k < num_searched; ++k) seen = seen || std::abs(searched[static_cast<std::size_t>(k)] - l) < 1e-3 * l;
    if (seen) continue;
    searched[static_cast<std::size_t>(num_searched++)] = l;
    local_search(l);
  }
  return sink.count();
}

bool TriangleOrientation(const std::array<Eigen::Vector3d, 3>& q_b, const std::array<Eigen::Vector3d, 3>& P_w,
                         BodyPose* pose) {
  Eigen::Matrix3d Fb, Fw;
  if (!TriangleFrame(q_b, &Fb) || !TriangleFrame(P_w, &Fw)) return false;
  pose->C_w_b = Fw * Fb.transpose();
  const Eigen::Vector3d qc = (q_b[0] + q_b[1] + q_b[2]) / 3.0;
  const Eigen::Vector3d Pc = (P_w[0] + P_w[1] + P_w[2]) / 3.0;
  pose->r_w_wb = Pc - pose->C_w_b * qc;
  return pose->C_w_b.allFinite() && pose->r_w_wb.allFinite();
}

bool AbsoluteOrientation(const std::array<Eigen::Vector3d, 3>& q_b, const std::array<Eigen::Vector3d, 3>& P_w,
                         BodyPose* pose) {
  const Eigen::Vector3d qc = (q_b[0] + q_b[1] + q_b[2]) / 3.0;
  const Eigen::Vector3d Pc = (P_w[0] + P_w[1] + P_w[2]) / 3.0;
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < 3; ++i) H += (q_b[i] - qc) * (P_w[i] - Pc).transpose();
  if (!H.allFinite()) return false;
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d s = svd.singularValues();
  if (!(s[1] > 1e-9 * s[0])) return false;  // collinear: rotation about the line is free
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  pose->C_w_b = svd.matrixV() * D * svd.matrixU().transpose();
  pose->r_w_wb = Pc - pose->C_w_b * qc;
  return pose->C_w_b.allFinite() && pose->r_w_wb.allFinite();
}

void SegmentDistanceRange(const BodyRay& r1, const BodyRay& r2, double lo, double hi, double* dmin,
                          double* dmax) {
  // Closest points of two segments (Ericson, Real-Time Collision Detection, 5.1.9).
  const Eigen::Vector3d p1 = r1.o_b + lo * r1.d_b, p2 = r2.o_b + lo * r2.d_b;
  const Eigen::Vector3d e1 = (hi - lo) * r1.d_b, e2 = (hi - lo) * r2.d_b;
  const Eigen::Vector3d r = p1 - p2;
  const double a = e1.squaredNorm(), e = e2.squaredNorm(), f = e2.dot(r);
  const double c = e1.dot(r), b = e1.dot(e2);
  const double denom = a * e - b * b;
  double s = denom > 1e-15 * a * e ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
  double t = (b * s + f) / e;
  if (t < 0.0) {
    t = 0.0;
    s = std::clamp(-c / a, 0.0, 1.0);
  } else if (t > 1.0) {
    t = 1.0;
    s = std::clamp((b - c) / a, 0.0, 1.0);
  }
  *dmin = ((p1 + s * e1) - (p2 + t * e2)).norm();
  // The distance is convex on the parameter square: its maximum is at a corner.
  *dmax = std::max(std::max(r.norm(), (r + e1).norm()), std::max((r - e2).norm(), (r + e1 - e2).norm()));
}

}  // namespace mfns::fw
