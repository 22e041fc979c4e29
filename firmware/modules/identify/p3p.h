// Generalized three-point pose (rays from several cameras) and absolute orientation.
//
// A blob of camera k is a ray in the body frame: origin r_b_bk, unit direction
// C_k_b^T [x_n; 1] / |.|. Three rays and three world beacons with mutual distances D_ij fix
// the body pose up to a few solutions: find depths l_i (along each unit ray, m) with
// |o_i + l_i d_i - o_j - l_j d_j| = D_ij for every pair, then the body-frame points
// q_i = o_i + l_i d_i and the beacons P_i give the pose by absolute orientation
// (P_w = C_w_b q_b + r_w_wb).
//
// Central case (the three rays from one camera, the common case in lost-in-space): Grunert's
// closed form. With s_2 = u s_1 and s_3 = v s_1, the ratios of the three distance equations
// give u as a rational function of v and a quartic in v, whose real roots are bracketed
// between the critical points (roots of its derivative, recursively) and polished; each root
// gives the depths, each solution is checked against all three distances.
//
// Other splits: l_2 and l_3 follow from l_1 through the (1,2)
// and (1,3) distance quadratics (two branches each); the (2,3) distance residual is then a
// function of l_1 alone for each of the four branch pairs. It is sampled on a geometric grid
// over [min_depth_m, max_depth_m], each sign change (including one at a branch's end, where
// its discriminant vanishes) is refined by bisection, and each extremum of the residual that
// heads towards zero between samples is searched (golden section) for a pair of close roots
// or a near-double root. Roots can still be missed where the residual bends sharply within
// one grid cell (near-degenerate geometry that hardly determines the pose).
//
// No heap, every loop bounded (scan steps, limits::kMaxBisectionIterations).
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
  int scan_steps = 128;      // grid samples of l_1, 8..limits::kMaxP3pScanSteps

  bool IsValid(const char** why = nullptr) const;
};

// The scan's part that depends on the rays only (reused for every beacon triple of a ray
// triple). Fixed storage.
class P3pRayTriple {
 public:
  // Precomputes the grid for rays[0..2]; false when the options are invalid.
  bool Set(const std::array<BodyRay, 3>& rays, const P3pOptions& options);

  // Solutions for beacons P_w[i] seen along rays[i]: writes up to limits::kMaxP3pSolutions
  // poses (body pose, C_w_b and r_w_wb) and, optionally, their depths; returns how many.
  int Solve(const std::array<Eigen::Vector3d, 3>& P_w, std::array<BodyPose, limits::kMaxP3pSolutions>* poses,
            std::array<Eigen::Vector3d, limits::kMaxP3pSolutions>* depths = nullptr) const;

 private:
  struct Sample {
    double l1;
    double m2, q2;  // ray 2: d2 . (P1 - o2) and |P1 - o2|^2 - m2^2 (squared distance to the ray)
    double m3, q3;
  };
  struct RayCoefficients {  // m(l) = a + b l, |P1 - o|^2 = c + 2 e l + l^2
    double a, b, c, e;
  };
  struct Distances {  // squared beacon distances
    double d12_sq, d13_sq, d23_sq;
  };
  Sample At(double l1) const;
  // Branch pair (s2, s3) at l1: false beyond a branch's end; otherwise the depths and
  // *f = |P2 - P3|^2 - D23^2.
  bool Eval(double l1, int s2, int s3, const Distances& D, double* f, double* l2, double* l3) const;
  bool BranchEnd(double lo, double hi, double near, const Distances& D, double* l1) const;
  bool Root(double a, double b, int s2, int s3, const Distances& D, double* l1) const;
  int SolveCentral(const std::array<Eigen::Vector3d, 3>& P_w, std::array<BodyPose, limits::kMaxP3pSolutions>* poses,
                   std::array<Eigen::Vector3d, limits::kMaxP3pSolutions>* depths) const;
  bool Extremum(double a, double b, int s2, int s3, const Distances& D, bool minimum, double* x, double* fx) const;

  std::array<BodyRay, 3> rays_{};
  P3pOptions options_{};
  bool central_ = false;                        // the three rays share their origin
  double cos_a_ = 0.0, cos_b_ = 0.0, cos_c_ = 0.0;  // angles between rays (2,3), (1,3), (1,2)
  RayCoefficients ray2_{}, ray3_{};
  double o23_sq_ = 0.0, d2_o23_ = 0.0, d3_o23_ = 0.0, d2_d3_ = 0.0;  // o23 = o2 - o3
  int n_ = 0;
  std::array<Sample, limits::kMaxP3pScanSteps> grid_{};
  double grid_min_ = 0.0, grid_max_ = 0.0;
  int grid_n_ = 0;
  std::array<double, limits::kMaxP3pScanSteps> depth_grid_{};
};

// The rigid transform with P_w[i] = C_w_b q_b[i] + r_w_wb for two congruent triangles (the
// P3P's: its depths reproduce the beacons' distances): the orthonormal frames of the two
// triangles, C_w_b = F_w F_b^T, about the centroids. No SVD; false when a triangle is
// (nearly) collinear or non-finite. For noisy, non-congruent points use AbsoluteOrientation.
bool TriangleOrientation(const std::array<Eigen::Vector3d, 3>& q_b, const std::array<Eigen::Vector3d, 3>& P_w,
                         BodyPose* pose);

// Real roots of c[0] + c[1] x + ... + c[n] x^n (n <= 4, c[n] != 0), ascending; returns how
// many. Each monotone stretch between the roots of the derivative (found the same way) that
// changes sign holds one root, found by safeguarded Newton steps; a double root where the
// polynomial only touches zero counts when it does so within rounding.
int PolynomialRealRoots(const double* c, int n, double* roots);

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
