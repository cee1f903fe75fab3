#pragma once
/// \file
/// The maps of `hapticctl report stability` (issue 12): where the wall, the
/// integrators and a sampled spring on the two-mass device are stable.
///  - Hulin's wall region in (beta, alpha) for delays d = 0..8, with the
///    design paths of Hulin 6.1 (maximum system damping) and 6.2 (minimum
///    pole radius) and the maxima of Remark 2;
///  - each integrator's stable region for the spring scene in the plane of
///    w_n T and the damping ratio zeta (Freudenberg 2.13-2.15 for forward
///    Euler: zeta > w_n T / 2);
///  - Diaz & Gil's critical stiffness K_CR against the loop delay td, rigid
///    and two-mass (motor and body sensing).

#include <optional>
#include <string>
#include <vector>

#include "analysis/study_progress.hpp"
#include "world/integrator.hpp"
#include "world/plant.hpp"

namespace hapticd::analysis {

/// Hulin 6.1: the discrete damping ratio of a pole z = e^{sT} is
/// D = -ln|z| / |ln z| = -ln r / sqrt(ln^2 r + theta^2) (the logarithmic
/// spirals of Fig. 8); the system's is the smallest over its poles.
/// 1 for z = 0 (and any pole on the positive real axis inside the circle).
double discrete_damping_ratio(double alpha, double beta, int delay_samples);

/// beta maximizing the system damping at this alpha over the stable beta
/// range (grid of 60, then golden section to 1e-10); nothing if no damping
/// stabilizes alpha.
struct MaximumDampingPoint {
  double alpha = 0.0;
  double beta = 0.0;
  double damping = 0.0;  ///< D there
};
std::optional<MaximumDampingPoint> maximum_damping_beta(double alpha, int delay_samples);

struct WallMapPoint {
  int delay = 0;
  double beta = 0.0;
  double alpha = 0.0;
};

struct WallRegionMap {
  std::vector<WallMapPoint> boundary;              ///< alpha_max(beta), beta log-spaced in (0, beta_max(0))
  std::vector<WallMapPoint> minimum_radius_path;   ///< Hulin 6.2
  std::vector<WallMapPoint> maximum_damping_path;  ///< Hulin 6.1
  std::vector<WallMapPoint> maximum_stiffness;     ///< Remark 2, one per d
};

/// d = 0 .. max_delay, `points` per curve.
WallRegionMap wall_region_map(int max_delay, int points, StudyProgress& progress);

/// Colgate & Schenkel's passivity boundary in the same plane (passivity.hpp):
/// for a device damping normalized as beta, device_beta = b T / m, the
/// largest passive alpha at each beta in (0, device_beta), d = 0 .. max_delay,
/// `points` per curve spaced as the stability boundary's (log-spaced from
/// device_beta * 1e-4, crowding toward device_beta where alpha falls to 0;
/// alpha = 0 itself is left out: the maps have log axes). Passive lies
/// below it, inside the stable region except near beta = 0, where the device's
/// own damping b (which Hulin's region, for b = 0, leaves out) is what holds.
std::vector<WallMapPoint> passivity_region_map(double device_beta, int max_delay, int points);

/// The stable zeta values of one integrator at one w_n T: [lower, upper]
/// (upper = +inf if stable up to the scan's top, 1e3); lower = 0 when the
/// undamped spring is stable. Several intervals are listed separately.
struct IntegratorRegionRow {
  world::Integrator integrator = world::Integrator::exact;
  double wn_t = 0.0;
  double zeta_lower = 0.0;
  double zeta_upper = 0.0;
};

/// analyze_integrator (the gate's verdict on the scene alone) on a grid of
/// w_n T in [1e-3, 1e3] (`per_decade`) and zeta in {0} and [1e-5, 1e3]
/// (8 per decade), each change of verdict bisected to 1e-9 relative.
std::vector<IntegratorRegionRow> integrator_region_map(const std::vector<world::Integrator>& integrators,
                                                       int per_decade, StudyProgress& progress);

struct CriticalStiffnessRow {
  std::string plant;  ///< "rigid", "two-mass"
  world::Sensor sensor = world::Sensor::motor;
  double delay_s = 0.0;
  double k_cr = 0.0;  ///< N/m (NaN when no finite value was found)
  double crossover_hz = 0.0;
};

/// Diaz & Gil Table I's LHifAM: rigid (m = m_m + m_d, b = b_m + b_d) with
/// motor sensing, two-mass with motor and body sensing, td = 0 .. max_delay_s.
std::vector<CriticalStiffnessRow> critical_stiffness_curves(double period_s, double max_delay_s,
                                                            double step_s, StudyProgress& progress);

/// The Jury closed form at td = 0 for the rigid plant 1/(m s^2 + b s) under a
/// ZOH: the loop z^2 + (K n1 - 1 - a) z + (a + K n0), a = e^{-bT/m},
/// n0 = (1 - a - (bT/m) a) m / b^2, is on the unit circle at a0 = 1, so
/// K_CR = (1 - a) / n0.
double rigid_critical_stiffness_jury(double mass, double damping, double period_s);

}  // namespace hapticd::analysis
