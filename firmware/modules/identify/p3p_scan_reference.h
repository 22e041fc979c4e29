// The generalized P3P as it was before the algebraic solve (session 8): Grunert's quartic for
// one camera (its quartic's roots by fw::PolynomialRealRoots, unchanged), a 1-D scan of l_1 for
// several. Test-only reference: p3p_test checks that the
// algebraic solver finds every solution this one finds. Not part of the flight library.
#pragma once

#include "firmware/modules/identify/p3p.h"

namespace mfns::fw::scan_reference {

// The scan's part that depends on the rays only (reused for every beacon triple of a ray
// triple). Fixed storage.
class ScanP3p {
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

}  // namespace mfns::fw::scan_reference
