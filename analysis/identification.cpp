#include "analysis/identification.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include <unsupported/Eigen/FFT>

#include "analysis/critical_stiffness.hpp"
#include "analysis/non_finite.hpp"
#include "analysis/verdict.hpp"

namespace hapticd::analysis {

namespace {

using non_finite::nan;

using cd = std::complex<double>;
constexpr double confounded_correlation = 0.99;
constexpr double confounded_spread = 0.05;  ///< a 95 % interval wider than 5 % of the value is loose

struct Units {
  std::string mass, damping, stiffness, force;
};

Units units_for(world::Motion motion) {
  if (motion == world::Motion::rotary) return {"kg m^2", "N m s/rad", "N m/rad", "N m"};
  return {"kg", "N s/m", "N/m", "N"};
}

/// What is fitted: the parameter vector's layout and the plant it makes.
struct Structure {
  IdentifiedPlant kind = IdentifiedPlant::rigid;
  HandCondition hand = HandCondition::free;
  world::Sensor sensor = world::Sensor::motor;
  std::vector<std::string> names;
  std::vector<std::string> units;
  Eigen::Index delay = -1;
  Eigen::Index coulomb = -1;  ///< -1: no friction term (the body is held)

  Eigen::Index index(std::string_view name) const {
    for (std::size_t i = 0; i < names.size(); ++i) {
      if (names[i] == name) return static_cast<Eigen::Index>(i);
    }
    return -1;
  }
  Eigen::Index size() const { return static_cast<Eigen::Index>(names.size()); }

  /// The plant for theta (false if a mass or stiffness is not > 0).
  bool plant(const Eigen::VectorXd& theta, world::LinearPlant& out) const;
};

Structure make_structure(IdentifiedPlant kind, HandCondition hand, world::Motion motion,
                         world::Sensor sensor) {
  const Units u = units_for(motion);
  Structure s;
  s.kind = kind;
  s.hand = hand;
  s.sensor = sensor;
  auto add = [&s](std::string name, std::string unit) {
    s.names.push_back(std::move(name));
    s.units.push_back(std::move(unit));
  };
  if (kind == IdentifiedPlant::rigid) {
    if (hand == HandCondition::hold) {
      throw std::invalid_argument(
          "a hand holding a rigid device still leaves nothing to measure: identify it free or held "
          "through a spring (--hand free | spring)");
    }
    add("mass", u.mass);
    add("damping", u.damping);
    if (hand == HandCondition::spring) add("hand_stiffness", u.stiffness);
  } else if (hand == HandCondition::hold) {
    if (sensor == world::Sensor::body) {
      throw std::invalid_argument(
          "the hand holds the body still and the encoder reads the body: nothing moves; identify the "
          "cable with the motor sensed, or let go (--hand free)");
    }
    add("motor_mass", u.mass);
    add("motor_and_cable_damping", u.damping);
    add("cable_stiffness", u.stiffness);
  } else {
    add("motor_mass", u.mass);
    add("body_mass", u.mass);
    add("motor_damping", u.damping);
    add("body_damping", u.damping);
    add("cable_stiffness", u.stiffness);
    add("cable_damping", u.damping);
    if (hand == HandCondition::spring) add("hand_stiffness", u.stiffness);
  }
  s.delay = s.size();
  add("delay", "periods");
  if (hand != HandCondition::hold) {
    s.coulomb = s.size();
    add("coulomb", u.force);
  }
  return s;
}

bool Structure::plant(const Eigen::VectorXd& t, world::LinearPlant& out) const {
  auto positive = [&](std::string_view name) {
    return t(index(name)) > 0.0 && std::isfinite(t(index(name)));
  };
  const Eigen::Index hand_k = index("hand_stiffness");
  if (hand_k >= 0 && !(t(hand_k) > 0.0)) return false;
  if (kind == IdentifiedPlant::rigid) {
    if (!positive("mass")) return false;
    out = world::RigidPlant{t(index("mass")), t(index("damping"))}.model();
    if (hand_k >= 0) out.dynamics.a(1, 0) = -t(hand_k) / t(index("mass"));
    return true;
  }
  if (hand == HandCondition::hold) {
    // The motor against a locked body: m_m x'' = F - (b_m + b_c) x' - k_c x.
    if (!positive("motor_mass") || !positive("cable_stiffness")) return false;
    const double m = t(index("motor_mass"));
    out.dynamics.a = Eigen::MatrixXd::Zero(2, 2);
    out.dynamics.a(0, 1) = 1.0;
    out.dynamics.a(1, 0) = -t(index("cable_stiffness")) / m;
    out.dynamics.a(1, 1) = -t(index("motor_and_cable_damping")) / m;
    out.dynamics.b = Eigen::MatrixXd::Zero(2, 2);
    out.dynamics.b(1, world::motor_force_input) = 1.0 / m;
    out.motor_position = Eigen::RowVectorXd::Unit(2, 0);
    out.body_position = Eigen::RowVectorXd::Zero(2);
    return true;
  }
  if (!positive("motor_mass") || !positive("body_mass") || !positive("cable_stiffness")) return false;
  const world::TwoMassPlant p{t(index("motor_mass")),      t(index("body_mass")),
                              t(index("motor_damping")),   t(index("body_damping")),
                              t(index("cable_stiffness")), t(index("cable_damping"))};
  out = p.model();
  if (hand_k >= 0) out.dynamics.a(3, 1) -= t(hand_k) / p.body_mass;  // the hand's spring on the body
  return true;
}

/// H(e^{j w T}) = C (zI - Phi)^{-1} (Gamma0 + Gamma1 / z) z^{-l} as
/// critical_stiffness.hpp's frequency_response, for the few states of these
/// plants without a heap allocation per frequency (a fit evaluates it for
/// thousands of bins, hundreds of times).
class SampledResponse {
 public:
  static constexpr std::size_t max_states = 4;

  SampledResponse(const DelayedZoh& sys, const Eigen::RowVectorXd& c) : n_(static_cast<int>(sys.phi.rows())) {
    for (int i = 0; i < n_; ++i) {
      for (int j = 0; j < n_; ++j) phi_[index(i, j)] = sys.phi(i, j);
      g0_[static_cast<std::size_t>(i)] = sys.gamma0(i);
      g1_[static_cast<std::size_t>(i)] = sys.gamma1(i);
      c_[static_cast<std::size_t>(i)] = c(i);
    }
    whole_ = sys.whole_samples;
    period_ = sys.period_s;
  }

  cd at(double w) const {
    const cd z = std::polar(1.0, w * period_);
    std::array<cd, max_states * max_states> m{};
    std::array<cd, max_states> x{};
    const auto at_ij = [this](int i, int j) { return index(i, j); };
    for (int i = 0; i < n_; ++i) {
      for (int j = 0; j < n_; ++j) m[at_ij(i, j)] = -phi_[at_ij(i, j)];
      m[at_ij(i, i)] += z;
      x[static_cast<std::size_t>(i)] =
          g0_[static_cast<std::size_t>(i)] + g1_[static_cast<std::size_t>(i)] * std::conj(z);  // 1/z, |z| = 1
    }
    // Gaussian elimination with partial pivoting (|re| + |im| as the size,
    // reciprocals by hand: std::complex's division checks for inf and NaN at
    // every call, which made this the fit's bottleneck).
    const auto size = [](const cd& v) { return std::abs(v.real()) + std::abs(v.imag()); };
    const auto inverse = [](const cd& v) { return std::conj(v) / std::norm(v); };
    for (int k = 0; k < n_; ++k) {
      int pivot = k;
      for (int i = k + 1; i < n_; ++i) {
        if (size(m[at_ij(i, k)]) > size(m[at_ij(pivot, k)])) pivot = i;
      }
      if (pivot != k) {
        for (int j = 0; j < n_; ++j) std::swap(m[at_ij(k, j)], m[at_ij(pivot, j)]);
        std::swap(x[static_cast<std::size_t>(k)], x[static_cast<std::size_t>(pivot)]);
      }
      const cd reciprocal = inverse(m[at_ij(k, k)]);
      for (int i = k + 1; i < n_; ++i) {
        const cd factor = m[at_ij(i, k)] * reciprocal;
        for (int j = k; j < n_; ++j) m[at_ij(i, j)] -= factor * m[at_ij(k, j)];
        x[static_cast<std::size_t>(i)] -= factor * x[static_cast<std::size_t>(k)];
      }
    }
    cd out = 0.0;
    for (int i = n_ - 1; i >= 0; --i) {
      cd acc = x[static_cast<std::size_t>(i)];
      for (int j = i + 1; j < n_; ++j) acc -= m[at_ij(i, j)] * x[static_cast<std::size_t>(j)];
      x[static_cast<std::size_t>(i)] = acc * inverse(m[at_ij(i, i)]);
      out += c_[static_cast<std::size_t>(i)] * x[static_cast<std::size_t>(i)];
    }
    return out;
  }

  /// z^{-l}, with the extra phase of a delay below 0 (a pure advance).
  cd delay_factor(double w, double advance_periods) const {
    return std::polar(1.0, -w * period_ * (static_cast<double>(whole_) + advance_periods));
  }

 private:
  std::size_t index(int i, int j) const {
    return static_cast<std::size_t>(i) * static_cast<std::size_t>(n_) + static_cast<std::size_t>(j);
  }

  int n_;
  int whole_ = 0;
  double period_ = 0.0;
  std::array<double, max_states * max_states> phi_{};
  std::array<double, max_states> g0_{}, g1_{}, c_{};
};

/// G_u (motor force, with the fitted delay) and G_h (a force on the mass or
/// body, no delay) at every bin. The delay below 0 (an advance: possible in a
/// fit, not in a device) continues as a pure phase so that the cost is smooth at 0.
bool responses(const Structure& s, const Eigen::VectorXd& theta, const FrequencyResponse& data,
               std::vector<cd>& gu, std::vector<cd>& gh) {
  world::LinearPlant plant;
  if (!s.plant(theta, plant)) return false;
  const double tau = theta(s.delay);
  if (!std::isfinite(tau) || tau > max_delay_periods || tau < -max_delay_periods) return false;
  const double t = data.period_s;
  const Eigen::RowVectorXd c = plant.position(s.sensor);
  const DelayedZoh motor = discretize_delayed_zoh(
      plant.dynamics.a, plant.dynamics.b.col(world::motor_force_input), t, std::max(tau, 0.0) * t);
  const DelayedZoh hand =
      discretize_delayed_zoh(plant.dynamics.a, plant.dynamics.b.col(world::hand_force_input), t, 0.0);
  if (!motor.phi.allFinite() || !motor.gamma0.allFinite() || !motor.gamma1.allFinite()) return false;
  const SampledResponse motor_response(motor, c);
  const SampledResponse hand_response(hand, c);
  gu.resize(data.size());
  gh.resize(data.size());
  for (std::size_t k = 0; k < data.size(); ++k) {
    const double w = 2.0 * std::numbers::pi * data.frequency_hz[k];
    gu[k] = motor_response.at(w) * motor_response.delay_factor(w, std::min(tau, 0.0));
    gh[k] = s.coulomb >= 0 ? hand_response.at(w) : cd(0.0);
  }
  return true;
}

Eigen::VectorXd residuals(const Structure& s, const Eigen::VectorXd& theta, const FrequencyResponse& data) {
  const Eigen::Index n = static_cast<Eigen::Index>(data.size());
  Eigen::VectorXd r(2 * n);
  std::vector<cd> gu, gh;
  if (!responses(s, theta, data, gu, gh)) return Eigen::VectorXd::Constant(2 * n, nan);
  const double fc = s.coulomb >= 0 ? theta(s.coulomb) : 0.0;
  for (Eigen::Index k = 0; k < n; ++k) {
    const auto i = static_cast<std::size_t>(k);
    const cd e = data.position[i] - gu[i] * data.force[i] - fc * gh[i] * data.friction_sign[i];
    r(2 * k) = e.real();
    r(2 * k + 1) = e.imag();
  }
  return r;
}

// ---- starting points -------------------------------------------------------

/// Equation error of a second-order model (a2 s^2 + a1 s + a0) Y = U e^{-s (tau + 1/2) T}
/// over the bins below 0.1/T (where the ZOH is about half a period of
/// delay): linear least squares in a2, a1 (and a0 when `with_stiffness`)
/// for each whole tau in 0..16; the best.
struct SecondOrder {
  double a2 = 0.0, a1 = 0.0, a0 = 0.0, tau = 0.0, error = std::numeric_limits<double>::infinity();
};

SecondOrder second_order(const FrequencyResponse& data, bool with_stiffness, double f_max) {
  std::vector<std::size_t> bins;
  for (std::size_t k = 0; k < data.size(); ++k) {
    if (data.frequency_hz[k] <= std::min(f_max, 0.1 / data.period_s)) bins.push_back(k);
  }
  if (bins.size() < 4) {
    for (std::size_t k = 0; k < std::min<std::size_t>(data.size(), 8); ++k) bins.push_back(k);
  }
  const Eigen::Index cols = with_stiffness ? 3 : 2;
  SecondOrder best;
  for (int tau = 0; tau <= 16; ++tau) {
    Eigen::MatrixXd a(2 * bins.size(), cols);
    Eigen::VectorXd b(2 * bins.size());
    double norm = 0.0;
    for (std::size_t i = 0; i < bins.size(); ++i) {
      const std::size_t k = bins[i];
      const double w = 2.0 * std::numbers::pi * data.frequency_hz[k];
      const cd s(0.0, w);
      const cd y = data.position[k] * std::polar(1.0, w * (tau + 0.5) * data.period_s);
      const cd u = data.force[k];
      const cd c2 = s * s * y, c1 = s * y;
      const auto row = static_cast<Eigen::Index>(2 * i);
      a(row, 0) = c2.real();
      a(row + 1, 0) = c2.imag();
      a(row, 1) = c1.real();
      a(row + 1, 1) = c1.imag();
      if (with_stiffness) {
        a(row, 2) = y.real();
        a(row + 1, 2) = y.imag();
      }
      b(row) = u.real();
      b(row + 1) = u.imag();
      norm += std::norm(u);
    }
    const Eigen::VectorXd x = a.colPivHouseholderQr().solve(b);
    const double error = (a * x - b).squaredNorm() / norm;
    if (error < best.error && x(0) > 0.0) {
      best = {x(0), std::max(x(1), 0.0), with_stiffness ? std::max(x(2), 0.0) : 0.0, static_cast<double>(tau),
              error};
    }
  }
  if (!std::isfinite(best.error)) {
    throw std::invalid_argument("the measured response does not look like a mass: no start for the fit");
  }
  return best;
}

/// The cable mode on top of the low-frequency model: R(w) = |G(w)| |a2 s^2 + a1 s + a0|
/// dips at the anti-resonance sqrt(k_c / m_d) and peaks at the resonance w_n.
struct CableMode {
  double anti = 0.0, resonance = 0.0, width = 0.0;
};

CableMode cable_mode(const FrequencyResponse& data, const SecondOrder& low) {
  std::vector<double> raw(data.size());
  for (std::size_t k = 0; k < data.size(); ++k) {
    const cd s(0.0, 2.0 * std::numbers::pi * data.frequency_hz[k]);
    raw[k] = std::abs(data.response(k)) * std::abs(low.a2 * s * s + low.a1 * s + low.a0);
  }
  // A running median over +-10 % in frequency: the encoder's quantization
  // makes single bins of a small response scatter by tens of percent.
  std::vector<double> ratio(data.size());
  std::size_t lo = 0, hi = 0;
  for (std::size_t k = 0; k < data.size(); ++k) {
    while (data.frequency_hz[lo] < data.frequency_hz[k] / 1.1) ++lo;
    while (hi + 1 < data.size() && data.frequency_hz[hi + 1] <= data.frequency_hz[k] * 1.1) ++hi;
    std::vector<double> window(raw.begin() + static_cast<long>(lo), raw.begin() + static_cast<long>(hi) + 1);
    std::nth_element(window.begin(), window.begin() + static_cast<long>(window.size() / 2), window.end());
    ratio[k] = window[window.size() / 2];
  }
  const auto dip = static_cast<std::size_t>(std::min_element(ratio.begin(), ratio.end()) - ratio.begin());
  const auto peak = static_cast<std::size_t>(
      std::max_element(ratio.begin() + static_cast<long>(dip), ratio.end()) - ratio.begin());
  if (!(ratio[dip] < 0.7 && ratio[peak] > 1.4 && peak > dip)) {
    throw std::invalid_argument("no cable mode in the excited band (the response follows a rigid mass from " +
                                short_number(data.frequency_hz.front()) + " to " +
                                short_number(data.frequency_hz.back()) +
                                " Hz): raise --end-frequency past the resonance, or fit --plant rigid");
  }
  CableMode m;
  m.anti = 2.0 * std::numbers::pi * data.frequency_hz[dip];
  m.resonance = 2.0 * std::numbers::pi * data.frequency_hz[peak];
  // Half-power width of the peak: the mode's z_n (s^2 + z_n s + w_n^2).
  const double half = ratio[peak] / std::sqrt(2.0);
  std::size_t below = peak, above = peak;
  while (below > dip && ratio[below] > half) --below;
  while (above + 1 < ratio.size() && ratio[above] > half) ++above;
  m.width = 2.0 * std::numbers::pi * (data.frequency_hz[above] - data.frequency_hz[below]);
  return m;
}

std::vector<Eigen::VectorXd> starting_points(const Structure& s, const FrequencyResponse& data) {
  const bool spring = s.hand == HandCondition::spring;
  std::vector<Eigen::VectorXd> starts;
  Eigen::VectorXd t = Eigen::VectorXd::Zero(s.size());
  if (s.kind == IdentifiedPlant::rigid || s.hand == HandCondition::hold) {
    const SecondOrder so =
        second_order(data, spring || s.hand == HandCondition::hold, std::numeric_limits<double>::infinity());
    t(0) = so.a2;
    t(1) = so.a1;
    if (s.size() > 2 && s.index("hand_stiffness") >= 0) t(s.index("hand_stiffness")) = so.a0;
    if (s.index("cable_stiffness") >= 0) t(s.index("cable_stiffness")) = so.a0;
    t(s.delay) = so.tau;
    starts.push_back(t);
    return starts;
  }
  // Two-mass: the rigid body from the lowest third of the band (log
  // frequency), then the cable from the anti-resonance and the resonance:
  // w_2^2 = k_c / m_d (12), w_n^2 = k_c m / (m_d m_m) (13) give m_m = m (w_2/w_n)^2.
  const double f_low =
      data.frequency_hz.front() * std::pow(data.frequency_hz.back() / data.frequency_hz.front(), 0.3);
  const SecondOrder so = second_order(data, spring, f_low);
  const CableMode mode = cable_mode(data, so);
  const double m = so.a2;
  const double m_m = m * (mode.anti / mode.resonance) * (mode.anti / mode.resonance);
  const double m_d = m - m_m;
  const double k_c = m_d * mode.anti * mode.anti;
  // z_n ~ b_c (1/m_m + 1/m_d) for small b_m, b_d (16).
  const double b_c = std::max(mode.width, 1e-3 * mode.resonance) / (1.0 / m_m + 1.0 / m_d);
  t(s.index("motor_mass")) = m_m;
  t(s.index("body_mass")) = m_d;
  t(s.index("motor_damping")) = so.a1 * m_m / m;
  t(s.index("body_damping")) = so.a1 * m_d / m;
  t(s.index("cable_stiffness")) = k_c;
  t(s.index("cable_damping")) = b_c;
  if (spring) t(s.index("hand_stiffness")) = std::max(so.a0, 1e-6 * k_c);
  t(s.delay) = so.tau;
  for (const double factor : {1.0, 0.3, 3.0}) {
    Eigen::VectorXd start = t;
    start(s.index("cable_damping")) *= factor;
    starts.push_back(start);
  }
  return starts;
}

Eigen::VectorXd scales(const Structure& s, const Eigen::VectorXd& start) {
  Eigen::VectorXd scale(s.size());
  double largest_damping = 0.0;
  for (Eigen::Index j = 0; j < s.size(); ++j) {
    if (s.units[static_cast<std::size_t>(j)].find(" s/") != std::string::npos) {
      largest_damping = std::max(largest_damping, std::abs(start(j)));
    }
  }
  for (Eigen::Index j = 0; j < s.size(); ++j) {
    const std::string& unit = s.units[static_cast<std::size_t>(j)];
    double typical = std::abs(start(j));
    if (j == s.delay) typical = 1.0;
    if (unit.find(" s/") != std::string::npos) typical = std::max(typical, 0.01 * largest_damping);
    if (j == s.coulomb) typical = std::max(typical, 1e-3);
    scale(j) = typical > 0.0 ? typical : 1e-3;
  }
  return scale;
}

void describe_results(const Structure& s, Identification& id) {
  const LeastSquaresFit& fit = id.fit;
  for (Eigen::Index j = 0; j < s.size(); ++j) {
    IdentifiedParameter p;
    p.name = s.names[static_cast<std::size_t>(j)];
    p.unit = s.units[static_cast<std::size_t>(j)];
    p.value = fit.parameters(j);
    p.half_width = fit.half_width(j);
    if (p.name == "damping" && s.hand == HandCondition::spring) p.note = "includes the hand's damping";
    if (p.name == "body_damping" && s.hand == HandCondition::spring) p.note = "includes the hand's damping";
    if (p.name == "motor_and_cable_damping") p.note = "b_m + b_c: the body held still cannot tell them apart";
    if (p.note.empty() && !(p.half_width < std::abs(p.value)) && j != s.delay && j != s.coulomb) {
      p.note = "not determined by the data: the 95 % interval includes 0";
    }
    id.parameters.push_back(std::move(p));
  }
  for (Eigen::Index i = 0; i < s.size(); ++i) {
    for (Eigen::Index j = i + 1; j < s.size(); ++j) {
      const double rho = fit.correlation(i, j);
      // Strongly correlated and at least one of them loose: only a
      // combination is known. (Correlated but both tight is no problem.)
      const auto loose = [&](Eigen::Index k) {
        return !(fit.half_width(k) <= confounded_spread * std::abs(fit.parameters(k)));
      };
      if (!(std::abs(rho) > confounded_correlation) || !(loose(i) || loose(j))) continue;
      Confounded c;
      c.first = s.names[static_cast<std::size_t>(i)];
      c.second = s.names[static_cast<std::size_t>(j)];
      c.correlation = rho;
      if (s.units[static_cast<std::size_t>(i)] == s.units[static_cast<std::size_t>(j)] && rho < 0.0) {
        // Negatively correlated and alike: the data fixes their sum.
        Eigen::VectorXd w = Eigen::VectorXd::Zero(s.size());
        w(i) = w(j) = 1.0;
        c.sum_name = c.first + " + " + c.second;
        c.sum = fit.parameters(i) + fit.parameters(j);
        c.sum_half_width = fit.half_width_of(w);
      }
      id.confounded.push_back(std::move(c));
    }
  }
}

}  // namespace

std::string_view to_string(IdentifiedPlant plant) noexcept {
  return plant == IdentifiedPlant::rigid ? "rigid" : "two-mass";
}

std::string_view to_string(HandCondition hand) noexcept {
  switch (hand) {
    case HandCondition::free:
      return "free";
    case HandCondition::hold:
      return "hold";
    case HandCondition::spring:
      return "spring";
  }
  return "free";
}

std::optional<IdentifiedPlant> parse_identified_plant(std::string_view text) noexcept {
  if (text == "rigid") return IdentifiedPlant::rigid;
  if (text == "two-mass" || text == "two_mass") return IdentifiedPlant::two_mass;
  return std::nullopt;
}

std::optional<HandCondition> parse_hand_condition(std::string_view text) noexcept {
  if (text == "free") return HandCondition::free;
  if (text == "hold") return HandCondition::hold;
  if (text == "spring") return HandCondition::spring;
  return std::nullopt;
}

FrequencyResponse measure_frequency_response(std::span<const double> position, std::span<const double> force,
                                             double period_s, std::int64_t sweep_steps, double f_low,
                                             double f_high, int skip) {
  if (!(period_s > 0.0) || sweep_steps < 4 || skip < 0) {
    throw std::invalid_argument("frequency response: period > 0, at least 4 samples per sweep, skip >= 0");
  }
  if (position.size() != force.size()) throw std::invalid_argument("frequency response: sizes differ");
  for (std::size_t i = 0; i < position.size(); ++i) {
    if (!std::isfinite(position[i]) || !std::isfinite(force[i])) {
      throw std::invalid_argument("frequency response: sample " + std::to_string(i) + " is not finite");
    }
  }
  const auto n = static_cast<std::size_t>(sweep_steps);
  const std::size_t available = position.size() / n;
  if (available < static_cast<std::size_t>(skip) + 1) {
    throw std::invalid_argument("frequency response: the record holds " + std::to_string(available) +
                                " whole sweeps; needs at least " + std::to_string(skip + 1));
  }
  const std::size_t first = static_cast<std::size_t>(skip);
  const std::size_t count = available - first;
  // Drift: y[n + (count-1) N] - y[n] = (count-1) N v T for a free device
  // with a constant velocity on top of its periodic motion.
  double slope = 0.0;
  if (count > 1) {
    for (std::size_t i = 0; i < n; ++i) {
      slope += position[(first + count - 1) * n + i] - position[first * n + i];
    }
    slope /= static_cast<double>(n) * static_cast<double>((count - 1) * n);
  }
  // -sign(v) with v from the central difference (0 where the encoder did not move).
  auto friction_at = [&](std::size_t i) {
    const double before = position[i == 0 ? 0 : i - 1];
    const double after = position[std::min(i + 1, position.size() - 1)];
    return after > before ? -1.0 : (after < before ? 1.0 : 0.0);
  };
  std::vector<double> y(n, 0.0), u(n, 0.0), f(n, 0.0);
  std::vector<std::vector<double>> per_sweep_y(count, std::vector<double>(n)), per_sweep_u = per_sweep_y;
  for (std::size_t p = 0; p < count; ++p) {
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t at = (first + p) * n + i;
      const double yi = position[at] - slope * static_cast<double>(at);
      per_sweep_y[p][i] = yi;
      per_sweep_u[p][i] = force[at];
      y[i] += yi / static_cast<double>(count);
      u[i] += force[at] / static_cast<double>(count);
      f[i] += friction_at(at) / static_cast<double>(count);
    }
  }
  Eigen::FFT<double> fft;
  std::vector<cd> yk, uk, fk;
  fft.fwd(yk, y);
  fft.fwd(uk, u);
  fft.fwd(fk, f);
  std::vector<std::vector<cd>> sweep_y(count), sweep_u(count);
  for (std::size_t p = 0; p < count; ++p) {
    fft.fwd(sweep_y[p], per_sweep_y[p]);
    fft.fwd(sweep_u[p], per_sweep_u[p]);
  }
  FrequencyResponse r;
  r.period_s = period_s;
  r.sweep_steps = sweep_steps;
  r.sweeps = static_cast<int>(count);
  const double bin = 1.0 / (static_cast<double>(n) * period_s);
  for (std::size_t k = 1; k < n / 2; ++k) {
    const double hz = static_cast<double>(k) * bin;
    if (hz < f_low || hz > f_high || std::abs(uk[k]) == 0.0) continue;
    r.frequency_hz.push_back(hz);
    r.force.push_back(uk[k]);
    r.position.push_back(yk[k]);
    r.friction_sign.push_back(fk[k]);
    const cd mean = yk[k] / uk[k];
    double variance = 0.0;
    for (std::size_t p = 0; p < count; ++p) variance += std::norm(sweep_y[p][k] / sweep_u[p][k] - mean);
    r.spread.push_back(count > 1 ? std::sqrt(variance / static_cast<double>(count - 1)) / std::abs(mean)
                                 : 0.0);
  }
  if (r.frequency_hz.empty()) {
    throw std::invalid_argument("frequency response: no harmonic of the sweep lies in the band " +
                                short_number(f_low) + " to " + short_number(f_high) + " Hz");
  }
  return r;
}

const IdentifiedParameter* Identification::find(std::string_view name) const noexcept {
  for (const auto& p : parameters) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

double Identification::value(std::string_view name) const {
  const IdentifiedParameter* p = find(name);
  if (p == nullptr) throw std::out_of_range("identification has no parameter " + std::string(name));
  return p->value;
}

Identification identify(const FrequencyResponse& data, IdentifiedPlant kind, HandCondition hand,
                        world::Motion motion, world::Sensor sensor) {
  const Structure s = make_structure(kind, hand, motion, sensor);
  if (data.size() * 2 < static_cast<std::size_t>(s.size()) + 2) {
    throw std::invalid_argument("too few frequencies in the band for " + std::to_string(s.size()) +
                                " parameters: sweep longer or wider");
  }
  Identification best;
  best.fit.cost = std::numeric_limits<double>::infinity();
  double total = 0.0;
  for (const cd& y : data.position) total += std::norm(y);
  for (const Eigen::VectorXd& start : starting_points(s, data)) {
    // The other starting points only when this one left a poor fit: on a
    // model that fits, the first lands within the encoder's noise.
    if (std::isfinite(best.fit.cost) && std::sqrt(best.fit.cost / total) < 1e-3) break;
    LeastSquaresProblem problem;
    problem.residuals = [&](const Eigen::VectorXd& theta) { return residuals(s, theta, data); };
    problem.start = start;
    problem.scale = scales(s, start);
    LeastSquaresFit fit;
    try {
      fit = levenberg_marquardt(problem);
    } catch (const std::invalid_argument&) {
      continue;  // a start whose residuals are not finite
    }
    if (fit.cost < best.fit.cost) best.fit = std::move(fit);
  }
  if (!std::isfinite(best.fit.cost)) throw std::invalid_argument("no starting point gave a finite fit");
  Identification& id = best;
  id.plant_kind = kind;
  id.hand = hand;
  describe_results(s, id);
  id.delay_periods = id.fit.parameters(s.delay);
  id.coulomb = s.coulomb >= 0 ? id.fit.parameters(s.coulomb) : 0.0;
  world::LinearPlant fitted_plant;
  s.plant(id.fit.parameters, fitted_plant);
  std::vector<cd> gu, gh;
  responses(s, id.fit.parameters, data, gu, gh);
  id.fitted = gu;
  id.fit_error = std::sqrt(id.fit.cost / total);
  id.complete = hand == HandCondition::free;
  if (!id.complete) {
    id.notes.push_back(
        hand == HandCondition::hold
            ? "the body was held: this identifies the motor and the cable only, not a device model"
            : "the hand's spring was fitted and its damping is part of the device's: not a "
              "device model for the gate (identify with --hand free for that)");
  }
  id.plant = fitted_plant;
  id.sensor = sensor;
  return best;
}

std::complex<double> identified_response(const Identification& id, double frequency_hz, double period_s) {
  const double tau = id.delay_periods;
  const DelayedZoh sys =
      discretize_delayed_zoh(id.plant.dynamics.a, id.plant.dynamics.b.col(world::motor_force_input), period_s,
                             std::max(tau, 0.0) * period_s);
  const double w = 2.0 * std::numbers::pi * frequency_hz;
  return frequency_response(sys, id.plant.position(id.sensor), w) *
         std::polar(1.0, -w * std::min(tau, 0.0) * period_s);
}

}  // namespace hapticd::analysis
