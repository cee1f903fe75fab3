// hapticctl: drive hapticd from the shell, and analyze stability offline.
// Exit codes: 0 ok, 1 refused by the daemon (or analyze cannot assess), 2 bad
// usage, 3 daemon unreachable.

#include <CLI/CLI.hpp>
#include <iostream>
#include <stdexcept>

#include "cli/analyze.hpp"
#include "cli/experiment.hpp"
#include "cli/report.hpp"
#include "cli/scope/scope.hpp"
#include "cli/usage_error.hpp"
#include "cli/verbs.hpp"

int main(int argc, char** argv) {
  CLI::App app{"hapticctl: control hapticd and analyze haptic stability"};
  app.require_subcommand(1);
  hapticctl::CommonOptions options;
  hapticctl::add_daemon_commands(app, options);
  hapticd::cli::add_analyze_command(app);
  hapticd::cli::add_report_command(app);
  hapticd::cli::add_tune_command(app, options);
  hapticd::cli::add_identify_command(app, options);
  hapticd::cli::scope::add_scope_command(app, options);
  try {
    return hapticctl::run(app, argc, argv);
  } catch (const hapticd::cli::CannotAssess& e) {
    std::cerr << "hapticctl: cannot assess: " << e.what() << "\n";
    return hapticd::cli::exit_refused;
  } catch (const hapticd::cli::UsageError& e) {
    std::cerr << "hapticctl: " << e.what() << "\n";
    return hapticd::cli::exit_usage;
  } catch (const std::invalid_argument& e) {
    std::cerr << "hapticctl: " << e.what() << "\n";
    return hapticd::cli::exit_usage;
  }
}
