#pragma once
/// \file
/// `hapticctl scope`: the daemon's live signals in a local, read-only web
/// page (docs/scope.md).

#include <string_view>

#include <CLI/CLI.hpp>

#include "cli/verbs.hpp"

namespace hapticd::cli::scope {

/// scope [--port N] [--no-browser] [--rate HZ]
void add_scope_command(CLI::App& app, hapticctl::CommonOptions& opts);

/// The page (cli/scope/scope_page.html, compiled in).
std::string_view page_html() noexcept;

}  // namespace hapticd::cli::scope
