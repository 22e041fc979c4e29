// Generalized three-point pose (rays from several cameras) and absolute orientation.
//
// A blob of camera k is a ray in the body frame: origin r_b_bk, unit direction
// C_k_b^T [x_n; 1] / |.|. Three rays and three world beacons with mutual distances D_ij fix
// the body pose up to a few solutions: find depths l_i (along each unit ray, m) with
// |o_i + l_i d_i - o_j - l_j d_j| = D_ij for every pair, then the body-frame points
// q_i = o_i + l_i d_i and the beacons P_i give the pose by absolute orientation
// (P_w = C_w_b q_b + r_w_wb).
//
// Central case (the three rays from one camera, the common case in lost-in-space): the two
// homogeneous conics in the depths (each distance equation against the one of the longest
// side) span a pencil; one real degenerate member (a root of a cubic, Cardano) is a pair of
// lines through the pencil's four base points, and each line meets a conic in two points (a
// quadratic). Depths are polished by Newton on the three distance equations (the idea of
// Lambda Twist, Persson & Nordberg ECCV 2018, and of Ding et al. CVPR 2023). A tangent line
// (a double root, the "twin" of a pose near the danger cylinder) is kept within rounding.
//
// Other splits: l_2 and l_3 follow from l_1 through the (1,2) and (1,3) distance quadratics
// (two branches each, l_k = m_k(l_1) +- sqrt(g_k(l_1))); the (2,3) distance residual is
// A + s_2 B r_2 + s_3 C r_3 + s_2 s_3 E r_2 r_3 with r_k = sqrt(g_k) and polynomials A, B, C, E.
// Squaring twice removes the square roots and the signs: one octic in l_1 whose roots are
// every branch pair's. Its real roots in [min_depth_m, max_depth_m] come from Bernstein
// subdivision (PolynomialRealRootsIn), with candidates where it only touches zero (near-double
// roots). Each candidate is assigned to the branch pairs whose residual nearly vanishes there
// and polished by Newton on the three distance equations; only solutions satisfying all three
// are kept. The two squarings cancel near close roots and branch ends (the octic's roots then
// move by up to ~1e-4 m or hide): where a polish fails or moves l_1 by more than 1e-7, the
// exact branch residuals are searched around the place (sign changes, dips, branch ends).
//
// Both cases: from every solution, its near twin (two solutions merging, J singular) is sought
// along the null direction of the distance equations' Jacobian and kept if it polishes to a
// solution; the tracker refuses an ambiguous three-beacon fix by seeing that twin.
//
// No heap, every loop bounded (fixed iteration and subdivision limits,
// limits::kMaxBisectionIterations).
#pragma once

#include <Eigen/Core>
#include <array>

#include "common/limits.h"
#include "common/rig/rig.h"
#include "firmware/modules/solve/observation.h"

namespace mfns::fw {

// A viewing ray in the body frame (m): points o_b + l d_b, l >= 0, d_b unit.
struct BodyRay {
  Eigen::Vector3d o_b = Eigen::Vector3d::Zero();
  Eigen::Vector3d d_b = Eigen::Vector3d::UnitZ();
};

// The ray of a blob (its camera must be valid for the rig).
BodyRay RayOfBlob(const Rig& rig, const BlobObs& blob);

struct P3pOptions {
  double min_depth_m = 0.1;  // beacons nearer a camera than this are not sought
  double max_depth_m = 5.0;  // nor farther
  // Grid samples of l_1 of the former 1-D scan, 8..limits::kMaxP3pScanSteps: still validated
  // (callers set it), unused since the algebraic solve.
  int scan_steps = 128;
  // Central triples (one camera) only: besides the exact roots, the point where a pair of
  // roots turned complex would merge (the real part of the pair), kept when the distance
  // equations hold there to this relative residual (0: exact roots only). Near the danger
  // cylinder centroid noise turns the true double root complex and the exact solve returns
  // nothing near the truth; lost-in-space scores these points like roots.
  double near_double_residual = 0.0;

  bool IsValid(const char** why = nullptr) const;
};

// The part that depends on the rays only (reused for every beacon triple of a ray triple).
// Fixed storage.
class P3pRayTriple {
 public:
  // Precomputes the ray geometry for rays[0..2]; false when the options are invalid.
  bool Set(const std::array<BodyRay, 3>& rays, const P3pOptions& options);

  // Solutions for beacons P_w[i] seen along rays[i]: writes up to limits::kMaxP3pSolutions
  // poses (body pose, C_w_b and r_w_wb) and, optionally, their depths; returns how many.
  int Solve(const std::array<Eigen::Vector3d, 3>& P_w, std::array<BodyPose, limits::kMaxP3pSolutions>* poses,
            std::array<Eigen::Vector3d, limits::kMaxP3pSolutions>* depths = nullptr) const;

 private:
  struct RayCoefficients {  // along ray 1 at depth l: m(l) = a + b l, |P1 - o|^2 = c + 2 e l + l^2
    double a, b, c, e;
  };
  int SolveCentral(const std::array<Eigen::Vector3d, 3>& P_w, std::array<BodyPose, limits::kMaxP3pSolutions>* poses,
                   std::array<Eigen::Vector3d, limits::kMaxP3pSolutions>* depths) const;
  int SolveGeneral(const std::array<Eigen::Vector3d, 3>& P_w, std::array<BodyPose, limits::kMaxP3pSolutions>* poses,
                   std::array<Eigen::Vector3d, limits::kMaxP3pSolutions>* depths) const;

  std::array<BodyRay, 3> rays_{};
  P3pOptions options_{};
  bool valid_ = false;
  bool central_ = false;                            // the three rays share their origin
  double cos_a_ = 0.0, cos_b_ = 0.0, cos_c_ = 0.0;  // angles between rays (2,3), (1,3), (1,2)
  RayCoefficients ray2_{}, ray3_{};
  double o23_sq_ = 0.0, d2_o23_ = 0.0, d3_o23_ = 0.0, d2_d3_ = 0.0;  // o23 = o2 - o3
};

// The rigid transform with P_w[i] = C_w_b q_b[i] + r_w_wb for two congruent triangles (the
// P3P's: its depths reproduce the beacons' distances): the orthonormal frames of the two
// triangles, C_w_b = F_w F_b^T, about the centroids. No SVD; false when a triangle is
// (nearly) collinear or non-finite. For noisy, non-congruent points use AbsoluteOrientation.
bool TriangleOrientation(const std::array<Eigen::Vector3d, 3>& q_b, const std::array<Eigen::Vector3d, 3>& P_w,
                         BodyPose* pose);

// Real roots of c[0] + c[1] x + ... + c[n] x^n (n <= 4, c[n] != 0), ascending; returns how
// many. (No longer used by the P3P itself; kept as a tested utility.) Each monotone stretch between the roots of the derivative (found the same way) that
// changes sign holds one root, found by safeguarded Newton steps; a double root where the
// polynomial only touches zero counts when it does so within rounding.
int PolynomialRealRoots(const double* c, int n, double* roots);

// Real roots of c[0] + ... + c[n] x^n (n <= 8) in [lo, hi], ascending; returns how many (at
// most n). Bernstein form on the interval, halved (de Casteljau) until Descartes' rule of signs
// shows no root or exactly one (then bracketed Newton steps); a piece narrower than 1e-7 of the
// interval that still may hold two or more roots is a cluster (a double root, or roots closer
// than that) and reported once, at its middle, for the caller to verify on its own equations.
int PolynomialRealRootsIn(const double* c, int n, double lo, double hi, double* roots);

// Least-squares rigid transform with P_w[i] = C_w_b q_b[i] + r_w_wb (Kabsch/Horn, SVD of the
// 3x3 cross-covariance, reflection excluded). False when the points are (nearly) collinear
// or non-finite.
bool AbsoluteOrientation(const std::array<Eigen::Vector3d, 3>& q_b, const std::array<Eigen::Vector3d, 3>& P_w,
                         BodyPose* pose);

// Smallest and largest distance between the points o1 + l1 d1 and o2 + l2 d2 for l1, l2 in
// [lo, hi]: every distance in between is reached (the set is connected).
void SegmentDistanceRange(const BodyRay& r1, const BodyRay& r2, double lo, double hi, double* dmin,
                          double* dmax);

}  // namespace mfns::fw
