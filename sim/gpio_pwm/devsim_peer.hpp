#pragma once
/// \file
/// `hapticd-devsim gpio-pwm -- hapticd --config config/gpio-pwm.toml`: runs
/// hapticd with the simulated gpio-pwm board inside it. The board cannot be a
/// process of its own: the fds libgpiod gets for its line requests must be
/// made in hapticd's process (sim/board_preload.cpp). So this peer sets the
/// environment (LD_PRELOAD of libumockdev-preload and
/// libhapticd-gpio-board.so, the board's options, plant and hand) and
/// executes the command after `--`.

#include "sim/devsim/peers.hpp"

namespace hapticd::drivers::gpio_pwm::sim {

devsim::SimulatedPeer gpio_pwm_peer();

}  // namespace hapticd::drivers::gpio_pwm::sim
