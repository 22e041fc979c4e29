// ChiSquareSurvival against closed forms: for even dof 2m the tail is
// exp(-x/2) sum_{i<m} (x/2)^i / i!, for dof 1 it is erfc(sqrt(x/2)); and table values.
#include "host/calib/uncertainty/chi_square.h"

#include <gtest/gtest.h>

#include <cmath>

namespace mfns::host {
namespace {

double EvenDofTail(double chi2, int dof) {
  const double h = 0.5 * chi2;
  double term = 1.0, sum = 0.0;
  for (int i = 0; i < dof / 2; ++i) {
    sum += term;
    term *= h / (i + 1);
  }
  return std::exp(-h) * sum;
}

TEST(ChiSquareSurvival, MatchesTheClosedFormsOverDofAndRange) {
  for (int dof = 2; dof <= 60; dof += 2)
    for (double chi2 : {0.01, 0.5, 1.0, 3.0, 9.9, 14.0, 30.0, 61.0, 100.0, 250.0}) {
      const double want = EvenDofTail(chi2, dof);
      EXPECT_NEAR(ChiSquareSurvival(chi2, dof), want, 1e-12 + 1e-10 * want) << "dof " << dof << " chi2 " << chi2;
    }
  for (double chi2 : {0.001, 0.3, 1.0, 2.5, 6.6, 20.0, 60.0})
    EXPECT_NEAR(ChiSquareSurvival(chi2, 1), std::erfc(std::sqrt(0.5 * chi2)), 1e-13) << chi2;
  EXPECT_EQ(ChiSquareSurvival(0.0, 14), 1.0);
  EXPECT_EQ(ChiSquareSurvival(-1.0, 3), 1.0);
}

TEST(ChiSquareSurvival, TableValues) {
  EXPECT_NEAR(ChiSquareSurvival(23.6848, 14), 0.05, 1e-5);   // the 95th percentile of chi-square(14)
  EXPECT_NEAR(ChiSquareSurvival(36.1233, 14), 0.001, 1e-6);  // the 99.9th
  EXPECT_NEAR(ChiSquareSurvival(7.81473, 3), 0.05, 1e-6);
  EXPECT_LT(ChiSquareSurvival(800.0, 14), 1e-150);
}

}  // namespace
}  // namespace mfns::host
