#pragma once
/// \file
/// One-dimensional minimization and root bisection shared by the analyses.

#include <cmath>
#include <utility>

namespace hapticd::analysis {

struct Minimum {
  double x = 0.0;
  double value = 0.0;
};

/// Golden-section search for a minimum of a unimodal f on [a, b], stopping
/// when the bracket is narrower than tol (or stops shrinking).
template <typename F>
Minimum golden_section_minimize(F&& f, double a, double b, double tol) {
  constexpr double inv_phi = 0.6180339887498949;  // (sqrt5 - 1)/2
  double c = b - inv_phi * (b - a);
  double d = a + inv_phi * (b - a);
  double fc = f(c);
  double fd = f(d);
  for (int i = 0; i < 200 && b - a > tol; ++i) {
    if (fc <= fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - inv_phi * (b - a);
      fc = f(c);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + inv_phi * (b - a);
      fd = f(d);
    }
  }
  return fc <= fd ? Minimum{c, fc} : Minimum{d, fd};
}

/// Grid of n interior points over (a, b), then golden section inside the
/// bracket around the best grid point: robust when f is unimodal only near
/// its minimum.
template <typename F>
Minimum grid_then_golden(F&& f, double a, double b, int n, double tol) {
  const double h = (b - a) / (n + 1);
  int best = 1;
  double best_value = f(a + h);
  for (int i = 2; i <= n; ++i) {
    const double v = f(a + i * h);
    if (v < best_value) {
      best_value = v;
      best = i;
    }
  }
  Minimum m = golden_section_minimize(f, a + (best - 1) * h, a + (best + 1) * h, tol);
  if (best_value < m.value) m = {a + best * h, best_value};
  return m;
}

/// Root of f in [lo, hi] where f changes sign (f_lo = f(lo), nonzero):
/// bisection until the bracket is narrower than tol or stops shrinking.
/// Returns the midpoint of the last bracket, or the point where f is 0.
template <typename F>
double bisect_sign_change(F&& f, double lo, double hi, double f_lo, double tol) {
  while (hi - lo > tol) {
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;
    const double f_mid = f(mid);
    if (f_mid == 0.0) return mid;
    if ((f_mid > 0.0) == (f_lo > 0.0)) {
      lo = mid;
      f_lo = f_mid;
    } else {
      hi = mid;
    }
  }
  return 0.5 * (lo + hi);
}

}  // namespace hapticd::analysis
