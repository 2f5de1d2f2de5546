// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file manual.h
/// Each tool's man page and bash completion, generated from its CLI11 options, so that a new
/// option appears in --help, the man page and completion without a second edit. The build
/// runs `TOOL --man` and `TOOL --bash-completion` (cli::run() answers both before parsing) and
/// installs what they print (tools/CMakeLists.txt; docs/install.md).

#include <CLI/CLI.hpp>

#include <string>

namespace nebula::cli {

/// The man page (roff, section 1) of @p app, named @p tool, whose whole description is
/// @p description: NAME (its first line), SYNOPSIS, DESCRIPTION (the rest: every example, the
/// method, the grids written, the caveats), OPTIONS (each option of the app and its option
/// groups, one subsection per group, with its value type, default and whether it is
/// required), EXIT STATUS, SEE ALSO.
std::string manPage(CLI::App& app, const std::string& tool, const std::string& description);

/// What --help says before the options, from a tool's whole @p description ("tool - purpose",
/// a blank line, "Examples:" and the examples, then prose): the purpose line, the first
/// MAX_HELP_EXAMPLES examples (an example is a line indented two spaces and the more deeply
/// indented lines that continue it), and a line naming the man page, which holds the rest.
std::string shortHelp(const std::string& description, const std::string& tool);
inline constexpr int MAX_HELP_EXAMPLES = 5;

/// A bash completion script for @p tool: `complete -F _nebula_<tool> <tool>`, offering every
/// option name after a dash, file names for an option's value and for arguments.
std::string bashCompletion(CLI::App& app, const std::string& tool);

} // namespace nebula::cli
