#include "nebula/cli/cli.h"

#include "nebula/core/error.h"

#include <fmt/format.h>
#include <openvdb/openvdb.h>
#include <tbb/global_control.h>

#include <cmath>
#include <iostream>
#include <sstream>
#include <unistd.h>

namespace nebula {

namespace cli {

std::string versionString(const std::string& tool)
{
    return tool + " " NEBULA_VERSION_STRING " (OpenVDB " +
           std::string(openvdb::getLibraryVersionString()) + ")";
}

void addCommon(CLI::App& app, CommonOptions& opts, unsigned flags)
{
    if (flags & INPUT) {
        app.add_option("-i,--input", opts.input, "Input VDB file, or - for stdin")->required();
    }
    if (flags & OUTPUT) {
        app.add_option("-o,--output", opts.output, "Output file, or - for stdout")->required();
    }
    if (flags & PASS_THROUGH) {
        app.add_flag("--only-new", opts.onlyNew,
                     "Write only this tool's own grids, not the input grids passed through");
    }
    if (flags & DENSITY_GRID) {
        app.add_option("--density-grid", opts.densityGrid,
                       "Name of the dust density grid (n_H [cm^-3])")
            ->capture_default_str();
    }
    app.add_option("--threads", opts.threads, "Worker threads (0 = all cores)")
        ->capture_default_str()
        ->check(CLI::NonNegativeNumber);
    app.add_flag("-q,--quiet", opts.quiet, "No progress bar or warnings");
    app.add_flag("-v,--verbose", opts.verbose, "Report each stage on stderr");
    app.set_version_flag("--version", versionString(app.get_name()));
    app.set_config("--config", "", "Read options from a TOML file (CLI11 format)");
    // A misspelt key in a config file is an error, as a misspelt option is on the command line.
    app.allow_config_extras(CLI::config_extras_mode::error);
}

std::array<double, 3> parseVec3(const std::string& text, const std::string& option)
{
    const std::string expected = option + " \"" + text + "\": expected X,Y,Z (three numbers)";
    std::vector<std::string> parts;
    std::istringstream in(text);
    for (std::string item; std::getline(in, item, ',');)
        parts.push_back(item);
    if (parts.size() != 3 || text.back() == ',') throw UsageError(expected);
    std::array<double, 3> v{};
    for (int i = 0; i < 3; ++i) {
        try {
            std::size_t used = 0;
            v[i] = std::stod(parts[i], &used);
            if (used != parts[i].size() || !std::isfinite(v[i])) throw UsageError(expected);
        } catch (const std::exception&) {
            throw UsageError(expected);
        }
    }
    return v;
}

namespace {

std::string vec3Text(double x, double y, double z)
{
    return fmt::format("{},{},{}", x, y, z);
}

} // namespace

CLI::Option* addVec3(CLI::App& app, const std::string& name, std::array<double, 3>& target,
                     const std::string& description)
{
    const std::string option = name.substr(name.rfind(',') + 1); // "-e,--eye" -> "--eye"
    return app
        .add_option_function<std::string>(
            name, [&target, option](const std::string& text) { target = parseVec3(text, option); },
            description)
        ->type_name("X,Y,Z")
        ->default_str(vec3Text(target[0], target[1], target[2]));
}

CLI::Option* addVec3(CLI::App& app, const std::string& name, Vec3& target,
                     const std::string& description)
{
    const std::string option = name.substr(name.rfind(',') + 1);
    return app
        .add_option_function<std::string>(
            name,
            [&target, option](const std::string& text) {
                const auto v = parseVec3(text, option);
                target = Vec3(v[0], v[1], v[2]);
            },
            description)
        ->type_name("X,Y,Z")
        ->default_str(vec3Text(target.x, target.y, target.z));
}

void requireMode(const std::vector<CLI::Option*>& options, bool enabled, const std::string& mode)
{
    if (enabled) return;
    for (const auto* opt : options) {
        if (opt->count() > 0) throw UsageError(opt->get_name() + " needs " + mode);
    }
}

void parseResolution(const std::string& text, int& width, int& height)
{
    const auto x = text.find('x');
    try {
        if (x == std::string::npos) throw std::invalid_argument(text);
        std::size_t u1 = 0, u2 = 0;
        const std::string a = text.substr(0, x), b = text.substr(x + 1);
        const int w = std::stoi(a, &u1), h = std::stoi(b, &u2);
        if (u1 != a.size() || u2 != b.size() || w <= 0 || h <= 0 || w > 65536 || h > 65536) {
            throw std::invalid_argument(text);
        }
        width = w;
        height = h;
    } catch (const std::exception&) {
        throw UsageError("--res \"" + text +
                         "\": expected WxH with positive integers, e.g. 512x512");
    }
}

namespace {

std::string joinCommand(int argc, char** argv)
{
    std::string cmd;
    for (int i = 0; i < argc; ++i) {
        if (i) cmd += ' ';
        const std::string arg = argv[i];
        const bool plain =
            !arg.empty() && arg.find_first_of(" \t\n'\"\\$`*?[]{}()<>|&;#~") == std::string::npos;
        if (plain) {
            cmd += arg;
        } else {
            cmd += '\'';
            for (char c : arg)
                cmd += (c == '\'') ? std::string("'\\''") : std::string(1, c);
            cmd += '\'';
        }
    }
    return cmd;
}

} // namespace

int run(CLI::App& app, const std::string& tool, CommonOptions& opts, int argc, char** argv,
        const std::function<void(Run&)>& body)
{
    try {
        app.parse(argc, argv);
    } catch (const UsageError& e) { // from an option's callback (addVec3)
        std::cerr << tool << ": error: " << e.what() << "\n"
                  << "Run " << tool << " --help for the options and examples.\n";
        return 2;
    } catch (const CLI::ParseError& e) {
        if (e.get_exit_code() == 0) return app.exit(e); // --help, --version: stdout, 0
        std::string message = e.what();
        // CLI11 says "INI was not able to parse KEY" for a key of a --config file that is no
        // option of this tool.
        const std::string extras = "INI was not able to parse ";
        if (dynamic_cast<const CLI::ConfigError*>(&e) && message.rfind(extras, 0) == 0) {
            message = "--config: unknown option \"" + message.substr(extras.size()) +
                      "\" in the config file (not an option of " + tool + ")";
        }
        std::cerr << tool << ": error: " << message << "\n"
                  << "Run " << tool << " --help for the options and examples.\n";
        return 2;
    }
    try {
        openvdb::initialize();
        std::unique_ptr<tbb::global_control> threads;
        if (opts.threads > 0) {
            threads = std::make_unique<tbb::global_control>(
                tbb::global_control::max_allowed_parallelism, std::size_t(opts.threads));
        }
        Run run(tool, joinCommand(argc, argv), Verbosity{opts.quiet, opts.verbose});
        body(run);
        return 0;
    } catch (const UsageError& e) {
        std::cerr << tool << ": error: " << e.what() << "\n";
        return 2;
    } catch (const std::exception& e) {
        std::cerr << tool << ": error: " << e.what() << "\n";
        return 1;
    }
}

} // namespace cli

} // namespace nebula
