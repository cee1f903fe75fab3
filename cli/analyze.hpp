#pragma once
/// \file
/// `hapticctl analyze ...`: offline stability and critical-stiffness answers,
/// no daemon needed. SI units; durations take s, ms or us.

#include <CLI/CLI.hpp>

namespace hapticd::cli {

/// Adds `analyze` with its subcommands: integrator, wall, boundary, critical-stiffness, passivity.
void add_analyze_command(CLI::App& app);

}  // namespace hapticd::cli
