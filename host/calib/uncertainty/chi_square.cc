#include "host/calib/uncertainty/chi_square.h"

#include <math.h>  // lgamma_r (POSIX): std::lgamma writes the global signgam

#include <cmath>

namespace mfns::host {
namespace {

constexpr double kEps = 1e-15;
constexpr int kMaxTerms = 1000;

double LogGamma(double a) {
  int sign = 0;
  return ::lgamma_r(a, &sign);
}

// P(a, x) by its power series (converges fast for x < a + 1).
double LowerSeries(double a, double x) {
  double term = 1.0 / a, sum = term;
  for (int n = 1; n < kMaxTerms && std::abs(term) > std::abs(sum) * kEps; ++n) {
    term *= x / (a + n);
    sum += term;
  }
  return sum * std::exp(-x + a * std::log(x) - LogGamma(a));
}

// Q(a, x) by its continued fraction (modified Lentz; converges fast for x > a + 1).
double UpperFraction(double a, double x) {
  constexpr double kTiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / kTiny, d = 1.0 / b, h = d;
  for (int i = 1; i < kMaxTerms; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < kTiny) d = kTiny;
    c = b + an / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < kEps) break;
  }
  return std::exp(-x + a * std::log(x) - LogGamma(a)) * h;
}

}  // namespace

double ChiSquareSurvival(double chi2, int dof) {
  if (!(chi2 > 0.0)) return 1.0;
  const double a = 0.5 * dof, x = 0.5 * chi2;
  return x < a + 1.0 ? 1.0 - LowerSeries(a, x) : UpperFraction(a, x);
}

}  // namespace mfns::host
