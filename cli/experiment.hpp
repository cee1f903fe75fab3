#pragma once
/// \file
/// Experiments on the device through the running daemon: `hapticctl tune
/// relay` (Diaz & Gil V: the critical stiffness by a relay) and `hapticctl
/// identify` (the device model from a chirp). Both restore the scene that
/// was loaded, on Ctrl-C too, and write their figures as `hapticctl report`
/// does (cli/report_figure.hpp).

#include <CLI/CLI.hpp>

#include "cli/verbs.hpp"

namespace hapticd::cli {

/// Exit code after Ctrl-C (128 + SIGINT).
inline constexpr int exit_experiment_interrupted = 130;

void add_tune_command(CLI::App& app, hapticctl::CommonOptions& options);
void add_identify_command(CLI::App& app, hapticctl::CommonOptions& options);

}  // namespace hapticd::cli
