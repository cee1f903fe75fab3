#pragma once
/// \file
/// The hand on a simulated pantograph's handle (issue 22), for the loopback:
/// the joints are two of the shared plant simulators (rigid, rotary: the
/// joint inertias and dampings; the links massless), and the hand acts in
/// task space on the handle, as a person holds a Haply or Hapkit. Its force
/// F reaches the joints as tau = J^T F (virtual work), or, held ideally, the
/// handle follows the reference and every joint with it.
///
/// A task hand script is a hand script (hand_script.hpp) along a task
/// direction d from a point o: the reference r(t) = o + s(t) d, with s(t)
/// the script's trajectory in m:
///   mode=free                    no hand
///   mode=force force=F           F d, N (from `at` on)
///   mode=impedance stiffness=K damping=B
///                                K (r - x) + B (r' - x'), both directions
///   mode=hold                    the handle on r(t) exactly: q = IK(r(t))
///   mode=hold ideal=false stiffness=K [damping=B]   as impedance
/// plus direction=dx,dy (default 1,0) and origin=ox,oy (m; default the
/// handle's start). A script whose reference leaves the reach of the
/// linkage is refused when set.
///
/// Threads: drives() belongs to the thread that steps the joints (the
/// loopback's RT thread): no allocation, no lock. set_script() runs on any
/// one other thread at a time (the writer side is serialized here), and
/// publishes through rt::Mailbox.

#include <array>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <string_view>

#include "drivers/simulation/hand_script.hpp"
#include "drivers/simulation/plant_simulator.hpp"
#include "rt/mailbox.hpp"
#include "world/kinematics.hpp"

namespace hapticd::drivers::simulation {

struct TaskHandScript {
  HandScript script;                          ///< the mode and s(t) along the direction, m
  std::array<double, 2> direction{1.0, 0.0};  ///< unit, in the task plane
  std::array<double, 2> origin{0.0, 0.0};     ///< o, m
  /// Back to key=value text (parse_task_hand_script(to_text()) == *this).
  std::string to_text() const;
  bool operator==(const TaskHandScript&) const = default;
};

/// Parses "direction=0,-1 mode=hold trajectory=ramp ..."; `origin` when
/// the text gives none; blank text is no hand (mode=free). Throws
/// ParameterError naming the key.
TaskHandScript parse_task_hand_script(std::string_view text, const std::array<double, 2>& origin);

class PantographHand {
 public:
  /// Throws std::invalid_argument when the script's reference leaves the reach.
  PantographHand(const world::PantographGeometry& geometry, const TaskHandScript& script, double period_s);
  PantographHand(const PantographHand&) = delete;
  PantographHand& operator=(const PantographHand&) = delete;

  /// Replaces the script (non-RT); it takes effect at the next drives().
  /// Throws std::invalid_argument when its reference leaves the reach.
  void set_script(const TaskHandScript& script);
  TaskHandScript script() const;
  /// The loop's period (before the loop runs).
  void set_period(double period_s) noexcept { period_s_ = period_s; }

  /// What the hand does to each joint over the coming period, at the
  /// joints' true positions and velocities (RT; period counts the steps).
  void drives(const std::array<double, 2>& q, const std::array<double, 2>& qd, std::uint64_t period,
              std::array<JointDrive, 2>& out) noexcept;

  const world::PantographKinematics& kinematics() const noexcept { return kinematics_; }

 private:
  /// The reference's range along d, in m: the trajectory's extremes.
  void check_reach(const TaskHandScript& script) const;
  void hold(const TaskHandScript& hand, double t_next, std::array<JointDrive, 2>& out) const noexcept;

  world::PantographKinematics kinematics_;
  double period_s_;
  rt::Mailbox<TaskHandScript> scripts_;
  mutable std::mutex writer_;  ///< set_script()/script() only; never the RT side
  TaskHandScript last_;        ///< under writer_: what was published last
  // RT-owned.
  const TaskHandScript* active_ = nullptr;
  std::uint64_t start_period_ = 0;
};

}  // namespace hapticd::drivers::simulation
