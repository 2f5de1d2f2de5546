// SPDX-License-Identifier: Apache-2.0
#include "nebula/cli/option_table.h"

#include "nebula/cli/cli.h"

#include <type_traits>

namespace nebula::cli {

namespace {

template <typename T> struct IsOptional : std::false_type
{
};
template <typename T> struct IsOptional<std::optional<T>> : std::true_type
{
};

/// The option of @p row, declared on @p app by the kind of its target.
CLI::Option* declare(CLI::App& app, const OptionRow& row)
{
    return std::visit(
        [&](auto* target) -> CLI::Option* {
            using T = std::remove_pointer_t<decltype(target)>;
            if constexpr (std::is_same_v<T, bool>) {
                return app.add_flag(row.name, *target, row.help);
            } else if constexpr (std::is_same_v<T, std::array<double, 3>>) {
                return addVec3(app, row.name, *target, row.help);
            } else if constexpr (IsOptional<T>::value) {
                return app.add_option(row.name, *target, row.help);
            } else {
                CLI::Option* option = app.add_option(row.name, *target, row.help);
                return row.showDefault ? option->capture_default_str() : option;
            }
        },
        row.target);
}

} // namespace

std::vector<CLI::Option*> addOptions(CLI::App& app, const std::vector<OptionRow>& rows)
{
    std::vector<CLI::Option*> options;
    for (const auto& row : rows) {
        CLI::Option* option = declare(app, row);
        if (row.check) option->check(*row.check);
        if (!row.group.empty()) option->group(row.group);
        if (row.mode) row.mode->push_back(option);
        options.push_back(option);
    }
    return options;
}

std::string argumentOf(int argc, const char* const* argv, const std::string& option)
{
    const std::string prefix = option + "=";
    std::string value;
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        if (arg == "--") break;
        if (arg == option && i + 1 < argc) {
            value = argv[i + 1];
        } else if (arg.compare(0, prefix.size(), prefix) == 0) {
            value = arg.substr(prefix.size());
        }
    }
    return value;
}

} // namespace nebula::cli
