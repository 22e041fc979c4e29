// The chi-square distribution's upper tail, for the consistency checks of a calibration
// (cross_validation.h): how likely a chi-square at least this large is when the covariance is
// right.
#pragma once

namespace mfns::host {

// P(X >= chi2) for X ~ chi-square with dof degrees of freedom (dof >= 1, chi2 >= 0): the
// regularised upper incomplete gamma function Q(dof / 2, chi2 / 2), by its series below
// a + 1 and its continued fraction above (relative error < 1e-12). 1 for chi2 <= 0.
double ChiSquareSurvival(double chi2, int dof);

}  // namespace mfns::host
