#pragma once
// Helpers shared by the world tests.

#include <algorithm>
#include <complex>
#include <vector>

#include <Eigen/Dense>

namespace hapticd::world::test {

inline std::vector<std::complex<double>> eigenvalues(const Eigen::MatrixXd& m) {
  Eigen::EigenSolver<Eigen::MatrixXd> solver(m, false);
  std::vector<std::complex<double>> out;
  for (Eigen::Index i = 0; i < solver.eigenvalues().size(); ++i) out.push_back(solver.eigenvalues()(i));
  return out;
}

inline double spectral_radius(const Eigen::MatrixXd& m) {
  double r = 0.0;
  for (const auto& l : eigenvalues(m)) r = std::max(r, std::abs(l));
  return r;
}

/// Roots of c[0] z^n + c[1] z^{n-1} + ... + c[n] (c[0] != 0) via the companion matrix.
inline std::vector<std::complex<double>> polynomial_roots(const std::vector<double>& c) {
  const auto n = static_cast<Eigen::Index>(c.size() - 1);
  Eigen::MatrixXd companion = Eigen::MatrixXd::Zero(n, n);
  for (Eigen::Index j = 0; j < n; ++j) companion(0, j) = -c[static_cast<std::size_t>(j + 1)] / c[0];
  for (Eigen::Index i = 1; i < n; ++i) companion(i, i - 1) = 1.0;
  return eigenvalues(companion);
}

/// Largest distance when matching each root of a to a distinct nearest root of b.
inline double match_roots(std::vector<std::complex<double>> a, std::vector<std::complex<double>> b) {
  if (a.size() != b.size()) return 1e300;
  double worst = 0.0;
  for (const auto& x : a) {
    auto best = b.begin();
    for (auto it = b.begin(); it != b.end(); ++it) {
      if (std::abs(*it - x) < std::abs(*best - x)) best = it;
    }
    worst = std::max(worst, std::abs(*best - x));
    b.erase(best);
  }
  return worst;
}

}  // namespace hapticd::world::test
