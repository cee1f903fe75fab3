#include "analysis/step_response.hpp"

#include <cmath>
#include <complex>

namespace hapticd::analysis {

FreeResponse free_response(double natural_frequency, double decay, double t) noexcept {
  const double q = natural_frequency * natural_frequency - decay * decay;  // w_d^2 (< 0: overdamped)
  const double fade = std::exp(-decay * t);
  if (q > 0.0) {
    const double wd = std::sqrt(q);
    // sin(w_d t) / w_d stays finite as w_d -> 0 (near critical damping).
    const double sin_over_wd = std::sin(wd * t) / wd;
    return {fade * (std::cos(wd * t) + decay * sin_over_wd), fade * sin_over_wd};
  }
  if (q < 0.0) {
    const double mu = std::sqrt(-q);
    if (mu * t < 20.0) {
      const double sinh_over_mu = std::sinh(mu * t) / mu;
      return {fade * (std::cosh(mu * t) + decay * sinh_over_mu), fade * sinh_over_mu};
    }
    // e^{-sigma t} cosh(mu t) as exponentials: no inf * 0 for large t.
    const double up = 0.5 * std::exp((mu - decay) * t);
    const double down = 0.5 * std::exp(-(mu + decay) * t);
    return {(up + down) + decay * (up - down) / mu, (up - down) / mu};
  }
  return {fade * (1.0 + decay * t), fade * t};
}

namespace {

struct PulseTerms {
  double position = 0.0;  ///< P(t)
  double velocity = 0.0;  ///< P'(t)
};

/// P(t), P'(t) for t >= tp. For an underdamped body with sigma tp < 1:
/// phi(t - tp) - phi(t) = Re(c e^{lambda t} E), h(t) - h(t - tp) =
/// -Im(e^{lambda t} E) / w_d, with lambda = -sigma + j w_d, c = 1 - j sigma/w_d
/// and E = e^{-lambda tp} - 1 from expm1 and 2 sin^2(w_d tp / 2).
PulseTerms pulse_after(const SecondOrderStep& s, double t) {
  const double wn = s.natural_frequency;
  const double sigma = s.decay;
  const double tp = s.pulse_width;
  const double q = wn * wn - sigma * sigma;
  if (q > 0.25 * wn * wn && sigma * tp < 1.0) {
    const double wd = std::sqrt(q);
    const double half = std::sin(0.5 * wd * tp);
    const std::complex<double> e_minus_1(std::expm1(sigma * tp) * std::cos(wd * tp) - 2.0 * half * half,
                                         -std::exp(sigma * tp) * std::sin(wd * tp));
    const std::complex<double> rotation = std::exp(-sigma * t) * std::polar(1.0, wd * t);
    const std::complex<double> product = rotation * e_minus_1;
    const std::complex<double> c(1.0, -sigma / wd);
    return {(c * product).real() / (wn * wn), -product.imag() / wd};
  }
  const FreeResponse now = free_response(wn, sigma, t);
  const FreeResponse before = free_response(wn, sigma, t - tp);
  return {(before.phi - now.phi) / (wn * wn), now.h - before.h};
}

}  // namespace

double SecondOrderStep::position(double t) const noexcept {
  const FreeResponse r = free_response(natural_frequency, decay, t);
  const double w2 = natural_frequency * natural_frequency;
  double e = initial * r.phi + forcing * (1.0 - r.phi) / w2;
  if (pulse != 0.0 && pulse_width > 0.0) {
    e += pulse * (t < pulse_width ? (1.0 - r.phi) / w2 : pulse_after(*this, t).position);
  }
  return e;
}

double SecondOrderStep::velocity(double t) const noexcept {
  const FreeResponse r = free_response(natural_frequency, decay, t);
  const double w2 = natural_frequency * natural_frequency;
  double v = (forcing - initial * w2) * r.h;
  if (pulse != 0.0 && pulse_width > 0.0) {
    v += pulse * (t < pulse_width ? r.h : pulse_after(*this, t).velocity);
  }
  return v;
}

}  // namespace hapticd::analysis
