#pragma once
/// \file
/// The study behind `hapticctl report passivity` (issue 21): Hulin's
/// unilateral wall (stiffness K, damping B, d samples late) on a rigid device
/// pushed by a hand and let go (analysis/passivity_contact.hpp), at stiffnesses
/// around the fixed-gain limit, each run twice: passivity = off and
/// passivity = controller (Hannaford & Ryu's observer and damper, its default
/// passivity_max_damping of 30 N s/m and no velocity deadband). What it
/// measures over the held push, from window_start_s to the hand's release:
///
///  - transparency: the force error e[n] = F[n] - F_ideal(y[n]), where F[n] is
///    the force the scene commanded for the position y[n] (delay, the wall's
///    damping B v and the controller's -alpha v included) and F_ideal the
///    ideal continuous spring wall at that same measured position,
///    F_ideal = -K y for y > 0 (penetrating), 0 otherwise; its RMS and its
///    peak |e|, in N and relative to the hand's push force
///    F_push = K k_h r / (K + k_h) (what the wall holds at rest);
///  - the controller's added damping alpha[n], its mean and peak over the
///    window (0 with passivity off);
///  - whether the run stayed bounded: diverged (the simulation stopped at
///    |y| > 1 m, |F| > 1e6 N or a value not finite), growing (the penetration's
///    oscillation over the last 0.1 s of the push is more than 1.05 x that
///    of 0.2 .. 0.3 s plus 1 um), else bounded. A value that is not finite is
///    never bounded;
///  - the late oscillation amplitude (half the peak-to-peak over the last
///    0.1 s of the push) against the static penetration k_h r / (K + k_h).
///
/// The simulation has no torque limit: a run that would saturate the motor
/// grows until it diverges instead (peak_force says how far it got).

#include <vector>

#include "analysis/passivity_contact.hpp"

namespace hapticd::analysis {

struct PassivityStudyOptions {
  double mass = 0.1;       ///< kg (Hulin section 7)
  double period_s = 1e-3;  ///< T
  double damping = 46.0;   ///< B, N s/m (beta = B T / m = 0.46)
  int delay = 1;           ///< d, samples (1..16)
  /// Stiffnesses as factors of the fixed-gain limit physical_stiffness(alpha_max(beta, d), m, T).
  std::vector<double> factors{0.5, 0.8, 1.0, 1.5, 2.0, 3.0, 5.0};
  double window_start_s = 0.2;  ///< s: the contact is established (the hand releases at 0.5 s)
  ContactHand hand{};
};

enum class ContactVerdict { bounded, growing, diverged };
const char* to_string(ContactVerdict verdict) noexcept;

struct PassivityRunSummary {
  ContactVerdict verdict = ContactVerdict::diverged;
  double rms_error = 0.0;       ///< N, over the window (NaN if the run stopped before it)
  double peak_error = 0.0;      ///< N
  double rms_relative = 0.0;    ///< rms_error / F_push
  double peak_relative = 0.0;   ///< peak_error / F_push
  double mean_damping = 0.0;    ///< N s/m, the controller's alpha over the window
  double peak_damping = 0.0;    ///< N s/m
  double peak_force = 0.0;      ///< N, the largest |F| of the whole run
  double late_amplitude = 0.0;  ///< m
  double late_ratio = 0.0;      ///< late_amplitude / static penetration
  double window_samples = 0.0;  ///< periods measured (fewer than the window if it diverged)
  ContactRun run;               ///< with its trace
};

struct PassivityStudyRow {
  double factor = 0.0;
  double stiffness = 0.0;           ///< K, N/m
  double static_penetration = 0.0;  ///< m
  double push_force = 0.0;          ///< F_push, N
  PassivityRunSummary off;
  PassivityRunSummary controller;
};

struct PassivityStudy {
  PassivityStudyOptions options;
  double fixed_gain_limit = 0.0;  ///< N/m
  double gate_factor = 0.0;       ///< passivity_stiffness_factor: the gate accepts the controller up to it
  double max_damping = 0.0;       ///< N s/m, the controller's passivity_max_damping
  std::vector<PassivityStudyRow> rows;
};

/// Throws std::invalid_argument on a parameter the scenes refuse (with the
/// scene's message) or a factor <= 0. Off the RT path.
PassivityStudy passivity_study(const PassivityStudyOptions& options);

/// The summary of one run (exposed for the tests).
PassivityRunSummary summarize_contact(ContactRun run, double stiffness, const ContactHand& hand,
                                      double window_start_s);

}  // namespace hapticd::analysis
