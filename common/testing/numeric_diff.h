// Central finite differences for checking analytic Jacobians in tests (header-only).
#pragma once

#include <Eigen/Core>

namespace mfns::testing {

// J(:, i) = (f(x + h e_i) - f(x - h e_i)) / (2 h_i), with h_i = step * max(1, |x_i|).
template <int M, int N, typename F>
Eigen::Matrix<double, M, N> CentralDiff(const F& f, const Eigen::Matrix<double, N, 1>& x,
                                        double step = 1e-6) {
  Eigen::Matrix<double, M, N> J;
  for (int i = 0; i < N; ++i) {
    const double h = step * std::max(1.0, std::abs(x[i]));
    Eigen::Matrix<double, N, 1> xp = x, xm = x;
    xp[i] += h;
    xm[i] -= h;
    J.col(i) = (f(xp) - f(xm)) / (2.0 * h);
  }
  return J;
}

}  // namespace mfns::testing
