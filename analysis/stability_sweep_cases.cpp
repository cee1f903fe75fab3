// The case list of the stability sweep (analysis/stability_sweep.hpp):
// deterministic, every family of issue 12, a subset for --quick.

#include <cmath>
#include <limits>
#include <numbers>

#include "analysis/critical_stiffness.hpp"
#include "analysis/non_finite.hpp"
#include "analysis/stability_sweep.hpp"
#include "analysis/wall_stability.hpp"
#include "world/integrator.hpp"
#include "world/text.hpp"

namespace hapticd::analysis {

namespace {

using non_finite::inf;
using non_finite::nan;

namespace d = world::scene_defaults;
constexpr double period = 1e-3;

std::string g(double v) { return world::text::format_significant(v, world::text::precision::message); }

/// The loopback wheel (J = 0.01 kg m^2) with a little friction, so that the
/// released spring's common drift decays instead of staying marginal.
GateDevice wheel_device(double t = period) { return rigid_device(0.01, 0.01, t, 0, world::Motion::rotary); }
/// Hulin's PHANToM-like device: m = 0.1 kg, no mechanical damping.
GateDevice hulin_device(double t = period, int delay = 0, double mass = d::hulin_mass) {
  return rigid_device(mass, 0.0, t, delay, world::Motion::linear);
}

SweepCase wheel(std::string family, std::string name, double k, double j, double b,
                world::Integrator integrator, SweepMode mode, GateDevice device) {
  SweepCase c;
  c.family = std::move(family);
  c.name = std::move(name);
  c.scene = "spring-wheel";
  c.parameters = {{"stiffness", k},
                  {"inertia", j},
                  {"damping", b},
                  {"damping_reference", std::string("absolute")},
                  {"integrator", std::string(world::to_string(integrator))}};
  c.mode = mode;
  c.device = std::move(device);
  return c;
}

SweepCase wall(std::string family, std::string name, double k, double b, int delay, GateDevice device) {
  SweepCase c;
  c.family = std::move(family);
  c.name = std::move(name);
  c.scene = "wall";
  c.parameters = {{"stiffness", k}, {"damping", b}, {"delay", static_cast<double>(delay)}};
  c.mode = SweepMode::released;
  c.device = std::move(device);
  c.hand_force = std::isfinite(k) && k > 0.0 ? k * 1e-3 : 1.0;  // 1 mm deep
  return c;
}

/// Normalized wall (Hulin eq. 2) on the device.
SweepCase normalized_wall(std::string family, std::string name, double alpha, double beta, int delay,
                          GateDevice device) {
  const double m = device.mass, t = device.period_s;
  const int scene_delay = std::min(delay, 16);
  device.delay_samples = delay - scene_delay;
  return wall(std::move(family), std::move(name), physical_stiffness(alpha, m, t),
              physical_damping(beta, m, t), scene_delay, std::move(device));
}

void integrator_family(std::vector<SweepCase>& out, bool quick) {
  const std::vector<double> hs = quick ? std::vector<double>{1e-3, 1, 2.9, 1e3}
                                       : std::vector<double>{1e-3, 0.1, 1, 1.9, 2.1, 2.8, 2.9, 10, 100, 1e3};
  const std::vector<double> zetas =
      quick ? std::vector<double>{0, 0.05} : std::vector<double>{0, 0.05, 2, 100};
  // At T = 10 ms w_n T = 1e3 needs k = 2.6e8 N m/rad on the wheel's J, inside
  // the catalog's range (k <= 1e9); at 1 ms it would be refused as invalid.
  const double j = d::wheel_inertia;
  const double t = 10e-3;
  for (const world::Integrator i : world::all_integrators) {
    for (const double h : hs) {
      for (const double zeta : zetas) {
        const double k = j * (h / t) * (h / t);
        out.push_back(
            wheel("w_n T",
                  std::string(world::to_string(i)) + " w_n T = " + g(h) + ", zeta = " + g(zeta) + " (held)",
                  k, j, 2.0 * zeta * std::sqrt(k * j), i, SweepMode::held, wheel_device(t)));
      }
    }
  }
}

void stiffness_family(std::vector<SweepCase>& out, bool quick) {
  const std::vector<double> ratios = quick ? std::vector<double>{1e-9, 1, 1e6, 1e12}
                                           : std::vector<double>{1e-9, 1e-6, 1e-3, 1, 1e3, 1e6, 1e9, 1e12};
  const double j = 1e-3;
  using world::Integrator;
  for (const double r : ratios) {
    const std::string what = "k/J = " + g(r) + " /s^2";
    if (quick) {
      out.push_back(wheel("k/J", what + ", exact (released)", r * j, j, 0.0, Integrator::exact,
                          SweepMode::released, wheel_device()));
      out.push_back(wheel("k/J", what + ", rk4 (held)", r * j, j, 0.0, Integrator::rk4, SweepMode::held,
                          wheel_device()));
      continue;
    }
    for (const Integrator i : {Integrator::exact, Integrator::trapezoid, Integrator::rk4}) {
      out.push_back(wheel("k/J", what + ", " + std::string(world::to_string(i)) + " (released)", r * j, j,
                          0.0, i, SweepMode::released, wheel_device()));
    }
    out.push_back(wheel("k/J", what + ", exact (held)", r * j, j, 0.0, Integrator::exact, SweepMode::held,
                        wheel_device()));
  }
}

void period_family(std::vector<SweepCase>& out, bool quick) {
  const std::vector<double> ts = quick ? std::vector<double>{20e-6, 1e-3, 50e-3}
                                       : std::vector<double>{20e-6, 100e-6, 1e-3, 10e-3, 50e-3};
  for (const double t : ts) {
    const std::string at = "T = " + g(t * 1e3) + " ms";
    out.push_back(wheel("period", "Freudenberg wheel, exact, " + at + " (released)", d::wheel_stiffness,
                        d::wheel_inertia, 0.0, world::Integrator::exact, SweepMode::released,
                        wheel_device(t)));
    if (!quick) {
      out.push_back(wheel("period", "forward Euler with b = T k, " + at + " (held)", d::wheel_stiffness,
                          d::wheel_inertia, t * d::wheel_stiffness, world::Integrator::forward_euler,
                          SweepMode::held, wheel_device(t)));
    }
    out.push_back(wall("period", "Hulin wall K = 9 kN/m, B = 46 N s/m, d = 1, " + at, d::wall_stiffness,
                       d::wall_damping, 1, hulin_device(t)));
  }
}

void delay_family(std::vector<SweepCase>& out, bool quick) {
  // d = 64 stays out of --quick: the gate's Hulin message for it takes seconds (max_stiffness_point).
  const std::vector<int> delays =
      quick ? std::vector<int>{0, 1, 8, 32} : std::vector<int>{0, 1, 2, 4, 8, 16, 32, 64};
  for (const int delay : delays) {
    // Half the largest damping that is stable as alpha -> 0 (near Remark 2's optimum beta).
    const double beta = 0.5 * beta_max_at_zero_stiffness(delay);
    const double top = alpha_max(beta, delay);
    for (const double factor : {0.5, 2.0}) {
      out.push_back(normalized_wall("delay",
                                    "wall d = " + std::to_string(delay) + ", alpha = " + g(factor) +
                                        " alpha_max(beta), beta = " + g(beta),
                                    factor * top, beta, delay, hulin_device()));
    }
  }
}

void inertia_family(std::vector<SweepCase>& out, bool quick) {
  const std::vector<double> masses =
      quick ? std::vector<double>{1e-9, 1, 1e6} : std::vector<double>{1e-9, 1e-6, 1e-3, 1, 1e3, 1e6};
  for (const double m : masses) {
    out.push_back(wall("inertia", "Hulin wall on m = " + g(m) + " kg", d::wall_stiffness, d::wall_damping, 1,
                       hulin_device(period, 0, m)));
  }
  const std::vector<double> inertias =
      quick ? std::vector<double>{1e-9, 1e6} : std::vector<double>{1e-9, 1e-6, 1e-3, 1, 1e3, 1e6};
  for (const double j : inertias) {
    out.push_back(wheel("inertia", "Freudenberg spring on J = " + g(j) + " kg m^2, exact (held)",
                        d::wheel_stiffness, j, 0.0, world::Integrator::exact, SweepMode::held,
                        wheel_device()));
  }
}

void damping_family(std::vector<SweepCase>& out, bool quick) {
  // d = 1: stable beta < 2 sqrt2 - 2 = 0.8284 as alpha -> 0 (Hulin Remark 2).
  const std::vector<double> betas =
      quick ? std::vector<double>{0, 0.2, 0.8293, 1000}
            : std::vector<double>{0, 0.05, 0.2, 0.4247, 0.8, 0.8293, 2, 10, 100, 1000};
  const std::vector<double> alphas = quick ? std::vector<double>{0.09} : std::vector<double>{0.01, 0.09};
  for (const double alpha : alphas) {
    for (const double beta : betas) {
      out.push_back(normalized_wall("damping", "wall d = 1, alpha = " + g(alpha) + ", beta = " + g(beta),
                                    alpha, beta, 1, hulin_device()));
    }
  }
}

/// Diaz & Gil's LHifAM (Table I) under a pure spring (a wall with B = 0,
/// d = 0): stable below K_CR, unstable above, motor and body sensing.
void two_mass_family(std::vector<SweepCase>& out, bool quick) {
  const world::TwoMassPlant plant;
  for (const world::Sensor sensor : {world::Sensor::motor, world::Sensor::body}) {
    GateDevice device;
    device.plant = plant.model();
    device.sensor = sensor;
    device.period_s = period;
    device.mass = plant.total_mass();
    device.damping = plant.total_damping();
    device.motion = world::Motion::linear;
    const double k_cr = critical_stiffness(device.plant, sensor, period, 0.0).k_cr;
    for (const double factor : {0.5, 1.5}) {
      if (quick && (sensor == world::Sensor::body || factor < 1.0)) continue;
      out.push_back(wall("two-mass",
                         "spring K = " + g(factor) + " K_CR (" + g(k_cr) + " N/m), " +
                             std::string(world::to_string(sensor)) + " sensing",
                         factor * k_cr, 0.0, 0, device));
    }
  }
}

void encoder_family(std::vector<SweepCase>& out, bool quick) {
  const double resolution = 2.0 * std::numbers::pi / 16384.0;  // the loopback's rotary encoder
  const auto jump = [&](SweepCase c) {
    c.fault = MeasurementFault::encoder_jump;
    c.fault_counts = 1e6;
    c.encoder_resolution = resolution;
    out.push_back(std::move(c));
  };
  jump(wheel("encoder", "1e6-count jump, exact wheel (released)", d::wheel_stiffness, d::wheel_inertia, 0.0,
             world::Integrator::exact, SweepMode::released, wheel_device()));
  if (quick) return;
  jump(wheel("encoder", "1e6-count jump, rk4 wheel (held)", d::wheel_stiffness, d::wheel_inertia, 0.0,
             world::Integrator::rk4, SweepMode::held, wheel_device()));
  SweepCase relative = wheel("encoder", "1e6-count jump, relative damping b = T k (released)",
                             d::wheel_stiffness, d::wheel_inertia, period * d::wheel_stiffness,
                             world::Integrator::exact, SweepMode::released, wheel_device());
  relative.parameters["damping_reference"] = std::string("relative");
  jump(std::move(relative));
}

void non_finite_family(std::vector<SweepCase>& out, bool quick) {
  const auto spring = [&](std::string name, double k, double j, double b, GateDevice device) {
    out.push_back(wheel("non-finite", std::move(name), k, j, b, world::Integrator::exact, SweepMode::released,
                        std::move(device)));
  };
  spring("stiffness NaN", nan, d::wheel_inertia, 0, wheel_device());
  if (!quick) {
    spring("stiffness Inf", inf, d::wheel_inertia, 0, wheel_device());
    spring("inertia NaN", d::wheel_stiffness, nan, 0, wheel_device());
    spring("inertia Inf", d::wheel_stiffness, inf, 0, wheel_device());
    spring("damping NaN", d::wheel_stiffness, d::wheel_inertia, nan, wheel_device());
    spring("damping Inf", d::wheel_stiffness, d::wheel_inertia, inf, wheel_device());
    spring("device inertia Inf", d::wheel_stiffness, d::wheel_inertia, 0,
           rigid_device(inf, 0.01, period, 0, world::Motion::rotary));
    spring("device period NaN", d::wheel_stiffness, d::wheel_inertia, 0, wheel_device(nan));
    out.push_back(wall("non-finite", "wall stiffness NaN", nan, d::wall_damping, 1, hulin_device()));
    out.push_back(wall("non-finite", "wall damping Inf", d::wall_stiffness, inf, 1, hulin_device()));
  }
  spring("device inertia NaN", d::wheel_stiffness, d::wheel_inertia, 0,
         rigid_device(nan, 0.01, period, 0, world::Motion::rotary));
  spring("device period Inf", d::wheel_stiffness, d::wheel_inertia, 0, wheel_device(inf));
  const auto measurement = [&](SweepCase c, MeasurementFault fault) {
    c.fault = fault;
    out.push_back(std::move(c));
  };
  measurement(wall("non-finite", "NaN position read, Hulin wall", d::wall_stiffness, d::wall_damping, 1,
                   hulin_device()),
              MeasurementFault::nan);
  if (quick) return;
  measurement(wall("non-finite", "Inf position read, Hulin wall", d::wall_stiffness, d::wall_damping, 1,
                   hulin_device()),
              MeasurementFault::inf);
  measurement(wheel("non-finite", "NaN position read, exact wheel (released)", d::wheel_stiffness,
                    d::wheel_inertia, 0, world::Integrator::exact, SweepMode::released, wheel_device()),
              MeasurementFault::nan);
  measurement(wheel("non-finite", "Inf position read, exact wheel (released)", d::wheel_stiffness,
                    d::wheel_inertia, 0, world::Integrator::exact, SweepMode::released, wheel_device()),
              MeasurementFault::inf);
}

}  // namespace

std::vector<SweepCase> sweep_cases(bool quick) {
  std::vector<SweepCase> out;
  integrator_family(out, quick);
  stiffness_family(out, quick);
  period_family(out, quick);
  delay_family(out, quick);
  inertia_family(out, quick);
  damping_family(out, quick);
  two_mass_family(out, quick);
  encoder_family(out, quick);
  non_finite_family(out, quick);
  return out;
}

}  // namespace hapticd::analysis
