#pragma once
/// \file
/// A hand pushing a rigid device into a scene and letting go, simulated off
/// the RT path: the study behind the passivity controller's tests and the
/// gate's factor for it (analysis/stability_gate.hpp). The device is a rigid
/// mass m with viscous damping b under the zero-order hold (exact
/// discretization of m y'' = F + F_hand - b y'); the hand is a passive
/// impedance, F_hand = k_h (r - y) - b_h y', sampled with the scene and held
/// over the period like the motor force, until it lets go.
///
/// The linear wall's growth or decay is in the stability gate already; this
/// is for what is not linear: the unilateral wall with its arming, and the
/// passivity controller switching its damping on and off.

#include <cstddef>
#include <vector>

#include "world/any_scene.hpp"

namespace hapticd::analysis {

struct ContactHand {
  double stiffness = 200.0;  ///< k_h, N/m: a relaxed human finger (Hannaford & Ryu's tests use such)
  double damping = 2.0;      ///< b_h, N s/m
  double reference = 5e-3;   ///< r, m: where the hand pulls the device to (past the wall surface at 0)
  double release_s = 0.5;    ///< s: the hand lets go (F_hand = 0 from here on)
};

struct ContactSetup {
  double mass = 0.1;            ///< kg
  double device_damping = 0.0;  ///< N s/m
  double period_s = 1e-3;
  double start = -1e-3;  ///< m: the device's position at rest when the hand starts pushing
  double duration_s = 1.0;
  ContactHand hand{};
  bool record_trace = false;  ///< fill ContactRun::trace (one sample a period)
  /// Periods between the force the scene commands and the period it acts in
  /// (a CiA 402 drive in cyclic synchronous torque: 1, at the next SYNC).
  int device_delay = 0;
};

/// One period of a run: the device's position at its start and what the
/// scene commanded from it (held over the period).
struct ContactSample {
  double time_s = 0.0;
  double position = 0.0;           ///< y[n], m (the wall surface at 0, inside for y > 0)
  double force = 0.0;              ///< N: the scene's output for y[n], passivity controller included
  double passivity_damping = 0.0;  ///< N s/m: the controller's alpha at n (0 without it)
  bool pushing = false;            ///< the hand still holds the device
};

/// The penetration over a stretch of the push.
struct ContactWindow {
  double mean = 0.0;       ///< m
  double amplitude = 0.0;  ///< m: half the peak-to-peak
};

struct ContactRun {
  bool diverged = false;  ///< |y| > 1 m, |F| > 1e6 N or a value not finite: stopped there
  double diverged_at_s = 0.0;
  /// The penetration from 0.2 to 0.3 s of the push and over its last 0.1 s:
  /// an oscillation that settles or stays bounded has late <= early.
  ContactWindow early{};
  ContactWindow late{};
  double peak_force = 0.0;              ///< N, the largest |F| the scene commanded
  double peak_passivity_damping = 0.0;  ///< N s/m, the controller's largest alpha (0 without it)
  double static_penetration = 0.0;      ///< m: the hand's push held by the linear wall, k_h r / (K + k_h)
  double release_velocity = 0.0;        ///< m/s, the device's velocity 0.1 s after the hand let go
  /// Every period run (the one that diverged included) when setup.record_trace; empty otherwise.
  std::vector<ContactSample> trace{};
};

/// Runs the scene (reset at setup.start) for setup.duration_s. wall_stiffness
/// (N/m) only sets static_penetration. Off the RT path.
ContactRun simulate_contact(world::AnyScene scene, const ContactSetup& setup, double wall_stiffness);

}  // namespace hapticd::analysis
