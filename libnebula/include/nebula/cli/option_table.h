// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file option_table.h
/// Options declared as data: a tool lists its options as rows (name, where the value goes,
/// help, check, group, the mode it belongs to) and addOptions() declares them on a CLI11 app,
/// in the order of the rows, as the chained add_option() calls would.

#include <CLI/CLI.hpp>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace nebula::cli {

/// Where an option's value goes. Its type is CLI11's (--help's INT, UINT, FLOAT, TEXT); a
/// bool is a flag; an X,Y,Z array takes "X,Y,Z" (addVec3()); an optional has no default.
using OptionTarget =
    std::variant<int*, std::uint64_t*, double*, std::optional<double>*,
                 std::optional<std::uint64_t>*, std::string*, bool*, std::array<double, 3>*>;

/// One option of a tool.
struct OptionRow
{
    std::string name; ///< "--res", or "-o,--output"
    OptionTarget target;
    std::string help;
    std::optional<CLI::Validator> check = std::nullopt; ///< integerIn(), numberIn(), IsMember
    std::string group = "";                             ///< "": CLI11's "Options"
    /// The options of a mode (requireMode()) this one joins; null: it means something in
    /// every mode.
    std::vector<CLI::Option*>* mode = nullptr;
    /// --help shows the target's value as the default (never for a flag, an optional or an
    /// X,Y,Z array, which shows its own).
    bool showDefault = true;
};

/// Declares @p rows on @p app (or an option group), in order. Returns the options declared,
/// in the same order.
std::vector<CLI::Option*> addOptions(CLI::App& app, const std::vector<OptionRow>& rows);

/// The value of @p option ("--preset") on the command line @p argv (as "--preset NAME" or
/// "--preset=NAME"; the last one given, none after "--"), or "" if it is not given: what a
/// tool needs before it defines its options (nebgen's preset sets their defaults).
std::string argumentOf(int argc, const char* const* argv, const std::string& option);

} // namespace nebula::cli
