#include "analysis/polynomial.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <Eigen/Dense>

#include "analysis/optimize.hpp"

namespace hapticd::analysis {

namespace {

using cd = std::complex<double>;

Polynomial trimmed(const Polynomial& p) {
  Polynomial q = p;
  while (!q.empty() && q.back() == 0.0) q.pop_back();
  return q;
}

double imag_cross(const Polynomial& p0, const Polynomial& p1, cd z) {
  return std::imag(evaluate(p0, z) * std::conj(evaluate(p1, z)));
}

double imag_cross(const Polynomial& p0, const Polynomial& p1, double theta) {
  return imag_cross(p0, p1, std::polar(1.0, theta));
}

/// The t for which p0 + t p1 vanishes at e^{j theta}, if it does (to rounding).
bool crossing_at(const Polynomial& p0, const Polynomial& p1, double theta, double& t) {
  const cd z = std::polar(1.0, theta);
  const cd a = evaluate(p0, z);
  const cd b = evaluate(p1, z);
  const double nb = std::norm(b);
  if (!(nb > 0.0)) return false;
  t = -std::real(a * std::conj(b)) / nb;
  const double residual = std::abs(a + t * b);
  return residual <= 1e-8 * (std::abs(a) + std::abs(t) * std::abs(b)) + 1e-300;
}

struct Grid {
  std::vector<double> theta;
  std::vector<cd> z;  // e^{j theta}, precomputed: the scan is the hot loop
};

Grid scan_grid() {
  constexpr int linear = 4096;
  constexpr int per_decade = 16;
  std::vector<double> grid;
  grid.reserve(linear + 2 * 8 * per_decade);
  for (int i = 1; i < linear; ++i) grid.push_back(std::numbers::pi * i / linear);
  // Crossings close to z = 1 and z = -1 (slow oscillations, Nyquist).
  for (int i = 0; i < 8 * per_decade; ++i) {
    const double h = std::pow(10.0, -9.0 + static_cast<double>(i) / per_decade);
    if (h < std::numbers::pi / linear) {
      grid.push_back(h);
      grid.push_back(std::numbers::pi - h);
    }
  }
  std::sort(grid.begin(), grid.end());
  Grid g{grid, {}};
  g.z.reserve(grid.size());
  for (double th : grid) g.z.push_back(std::polar(1.0, th));
  return g;
}

}  // namespace

std::complex<double> evaluate(const Polynomial& p, std::complex<double> z) noexcept {
  cd acc = 0.0;
  for (auto it = p.rbegin(); it != p.rend(); ++it) acc = acc * z + *it;
  return acc;
}

std::complex<double> evaluate_derivative(const Polynomial& p, std::complex<double> z) noexcept {
  cd acc = 0.0;
  for (std::size_t i = p.size(); i-- > 1;) acc = acc * z + static_cast<double>(i) * p[i];
  return acc;
}

Polynomial add_scaled(const Polynomial& a, double s, const Polynomial& b) {
  Polynomial r(std::max(a.size(), b.size()), 0.0);
  for (std::size_t i = 0; i < a.size(); ++i) r[i] += a[i];
  for (std::size_t i = 0; i < b.size(); ++i) r[i] += s * b[i];
  return r;
}

std::vector<std::complex<double>> roots(const Polynomial& p) {
  const Polynomial q = trimmed(p);
  if (q.size() <= 1) return {};
  const auto n = static_cast<Eigen::Index>(q.size() - 1);
  if (n == 1) return {cd(-q[0] / q[1], 0.0)};
  Eigen::MatrixXd companion = Eigen::MatrixXd::Zero(n, n);
  for (Eigen::Index i = 1; i < n; ++i) companion(i, i - 1) = 1.0;
  for (Eigen::Index i = 0; i < n; ++i) companion(i, n - 1) = -q[static_cast<std::size_t>(i)] / q.back();
  const Eigen::EigenSolver<Eigen::MatrixXd> solver(companion, false);
  const Eigen::VectorXcd& ev = solver.eigenvalues();
  return {ev.data(), ev.data() + ev.size()};
}

double root_radius(const Polynomial& p) {
  double r = 0.0;
  for (const cd& z : roots(p)) r = std::max(r, std::abs(z));
  return r;
}

std::vector<UnitCircleCrossing> unit_circle_crossings(const Polynomial& p0, const Polynomial& p1) {
  static const Grid scan = scan_grid();
  const std::vector<double>& grid = scan.theta;
  std::vector<UnitCircleCrossing> out;
  double t = 0.0;
  if (crossing_at(p0, p1, 0.0, t)) out.push_back({t, 0.0});
  if (crossing_at(p0, p1, std::numbers::pi, t)) out.push_back({t, std::numbers::pi});
  double prev_theta = grid.front();
  double prev_g = imag_cross(p0, p1, scan.z.front());
  for (std::size_t i = 1; i <= grid.size(); ++i) {
    const bool last = i == grid.size();
    const double theta = last ? prev_theta : grid[i];
    const double g = last ? prev_g : imag_cross(p0, p1, scan.z[i]);
    if (prev_g == 0.0) {
      if (crossing_at(p0, p1, prev_theta, t)) out.push_back({t, prev_theta});
    } else if (!last && g != 0.0 && (g > 0.0) != (prev_g > 0.0)) {
      const double root_theta = bisect_sign_change([&](double x) { return imag_cross(p0, p1, x); },
                                                   prev_theta, theta, prev_g, 1e-14);
      if (crossing_at(p0, p1, root_theta, t)) out.push_back({t, root_theta});
    }
    prev_theta = theta;
    prev_g = g;
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.t < b.t; });
  return out;
}

std::vector<Interval> stable_intervals(const Polynomial& p0, const Polynomial& p1, double t_min) {
  std::vector<double> cuts{t_min};
  for (const auto& c : unit_circle_crossings(p0, p1)) {
    // Crossings within rounding of t_min or of the previous cut are the same
    // point (e.g. the z = 1 root at t = 0 computed as 1e-17).
    const double tol = 1e-12 * (1.0 + std::abs(c.t));
    if (c.t > cuts.back() + tol) cuts.push_back(c.t);
  }
  cuts.push_back(std::numeric_limits<double>::infinity());
  std::vector<Interval> out;
  for (std::size_t i = 0; i + 1 < cuts.size(); ++i) {
    const double lo = cuts[i], hi = cuts[i + 1];
    const double mid = std::isinf(hi) ? 2.0 * std::abs(lo) + 1.0 : 0.5 * (lo + hi);
    if (root_radius(add_scaled(p0, mid, p1)) < 1.0) {
      if (!out.empty() && out.back().upper == lo) {
        out.back().upper = hi;
      } else {
        out.push_back({lo, hi});
      }
    }
  }
  return out;
}

}  // namespace hapticd::analysis
