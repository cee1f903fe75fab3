#pragma once
/// \file
/// Bad command-line input: hapticctl prints the one-line message and exits 2.
/// (CannotAssess below: exit 1.)

#include <stdexcept>
#include <string>

namespace hapticd::cli {

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// The analysis could not give its answer (its numbers overflowed or lost
/// precision, see analysis/verdict.hpp): hapticctl prints "cannot assess:
/// <reason>" and exits 1, after the result (with its verdict) is printed.
struct CannotAssess : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Exit codes shared by every verb.
enum ExitCode : int { exit_ok = 0, exit_refused = 1, exit_usage = 2, exit_unreachable = 3 };

}  // namespace hapticd::cli
