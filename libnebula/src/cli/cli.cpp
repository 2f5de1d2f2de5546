// SPDX-License-Identifier: Apache-2.0
#include "nebula/cli/cli.h"

#include "nebula/cli/manual.h"

#include "nebula/core/atomic_file.h"
#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/input.h"
#include "nebula/core/units.h"
#include "nebula/core/version.h"

#include <fmt/format.h>
#include <openvdb/openvdb.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <new>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <sys/mman.h>
#include <sys/stat.h>
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
        inputFile(
            app.add_option("-i,--input", opts.input, "Input VDB file, or - for stdin")->required());
    }
    if (flags & OUTPUT) {
        // A VDB unless the tool marks it again (nebrender: EXR; nebexport: its --format).
        outputFile(
            app.add_option("-o,--output", opts.output, "Output file, or - for stdout")->required(),
            FileFormat::Vdb);
    }
    if (flags & PASS_THROUGH) {
        opts.inPlace = true;
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
        ->check(integerIn(0, MAX_THREADS));
    app.add_flag("--write-through", opts.writeThrough,
                 "Write an output that is a FIFO, a device or a symbolic link through it "
                 "(without, such outputs are refused: regular files are replaced atomically)");
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
    for (double c : v) {
        if (std::fabs(c) > MAX_VEC3_COMPONENT) {
            throw UsageError(option + " \"" + text + "\": each number must be at most " +
                             detail::numberText(MAX_VEC3_COMPONENT) +
                             " in magnitude (lengths and distances are computed from squares, "
                             "which would overflow)");
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

void parseListen(const std::string& listen, std::string& address, std::uint16_t& port)
{
    const auto colon = listen.rfind(':');
    if (colon == std::string::npos || colon == 0) {
        throw UsageError("--listen " + listen + ": expected ADDR:PORT, e.g. 0.0.0.0:8080");
    }
    address = listen.substr(0, colon);
    if (address.size() > 2 && address.front() == '[' && address.back() == ']') {
        address = address.substr(1, address.size() - 2);
    }
    const std::string p = listen.substr(colon + 1);
    if (p.empty() || p.size() > 5 || p.find_first_not_of("0123456789") != std::string::npos ||
        std::stoi(p) > 65535) {
        throw UsageError("--listen " + listen + ": the port must be 0-65535");
    }
    port = std::uint16_t(std::stoi(p));
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
                         "\": expected WxH, each an integer in [1, 65536], e.g. 512x512");
    }
}

namespace {

// The marks of file options: validators that check nothing, found by name (a validator with
// no description adds nothing to --help).
const char* const INPUT_MARK = "nebula-input";
const std::string OUTPUT_MARK = "nebula-output:";
const char* const ANY_FORMAT = "any";

std::string outputMark(std::optional<FileFormat> format)
{
    return OUTPUT_MARK + (format ? std::to_string(int(*format)) : ANY_FORMAT);
}

/// The output mark of @p opt, or nullptr.
CLI::Validator* findOutputMark(CLI::Option& opt)
{
    for (int f = -1; f <= int(FileFormat::Json); ++f) {
        try {
            return opt.get_validator(
                outputMark(f < 0 ? std::nullopt : std::optional(FileFormat(f))));
        } catch (const CLI::OptionNotFound&) {
        }
    }
    return nullptr;
}

CLI::Validator markValidator(const std::string& name)
{
    return CLI::Validator([](std::string&) { return std::string(); }, "", name);
}

struct FileOption
{
    std::string option; ///< the option's name, or a derived output's label
    std::string path;
    std::optional<FileFormat> format;
};

/// The values of the options of @p app (and its option groups) marked as inputs (@p outputs
/// false) or outputs, "-" and "none" left out.
void markedFiles(const CLI::App& app, bool outputs, std::vector<FileOption>& files)
{
    for (const CLI::Option* o : app.get_options()) {
        auto* opt = const_cast<CLI::Option*>(o);
        std::optional<FileFormat> format;
        if (outputs) {
            const CLI::Validator* mark = findOutputMark(*opt);
            if (!mark) continue;
            const std::string id = mark->get_name().substr(OUTPUT_MARK.size());
            if (id != ANY_FORMAT) format = FileFormat(std::stoi(id));
        } else {
            try {
                opt->get_validator(INPUT_MARK);
            } catch (const CLI::OptionNotFound&) {
                continue;
            }
        }
        if (opt->count() == 0) continue;
        // As the user most likely typed it: -o rather than --output.
        const auto& shorts = opt->get_snames();
        const std::string label = shorts.empty() ? opt->get_name() : "-" + shorts.front();
        for (const auto& result : opt->results())
            if (!result.empty() && result != "-" && result != "none")
                files.push_back({label, result, format});
    }
    for (const CLI::App* group :
         app.get_subcommands([](const CLI::App* a) { return a->get_name().empty(); }))
        markedFiles(*group, outputs, files);
}

/// The absolute, normalised name of @p path, a dangling symbolic link followed to the name it
/// points to (a file that does not exist yet).
std::filesystem::path resolvedName(const std::string& path, std::error_code& ec)
{
    namespace fs = std::filesystem;
    fs::path p = fs::absolute(path, ec);
    std::error_code missing; // a name that does not exist is no link
    for (int hops = 0; !ec && hops < 40 && fs::is_symlink(fs::symlink_status(p, missing)); ++hops) {
        const fs::path target = fs::read_symlink(p, ec);
        p = target.is_absolute() ? target : p.parent_path() / target;
    }
    return ec ? p : fs::weakly_canonical(p, ec);
}

/// The same file: the same existing inode, or (for names that do not exist yet, and dangling
/// links to them) the same absolute, normalised name.
bool sameFile(const std::string& a, const std::string& b)
{
    struct stat sa, sb;
    const bool ea = ::stat(a.c_str(), &sa) == 0, eb = ::stat(b.c_str(), &sb) == 0;
    if (ea && eb) return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
    if (ea != eb) return false;
    std::error_code ec1, ec2;
    const auto na = resolvedName(a, ec1);
    const auto nb = resolvedName(b, ec2);
    return !ec1 && !ec2 && na == nb;
}

} // namespace

CLI::Option* inputFile(CLI::Option* option)
{
    try {
        option->get_validator(INPUT_MARK);
    } catch (const CLI::OptionNotFound&) {
        option->check(markValidator(INPUT_MARK));
    }
    return option;
}

CLI::Option* outputFile(CLI::Option* option, std::optional<FileFormat> format)
{
    if (CLI::Validator* mark = findOutputMark(*option)) {
        mark->name(outputMark(format));
    } else {
        option->check(markValidator(outputMark(format)));
    }
    return option;
}

std::vector<std::pair<std::string, std::string>> optionValues(const CLI::App& app,
                                                              const std::vector<std::string>& skip)
{
    std::vector<std::pair<std::string, std::string>> values;
    for (const CLI::Option* opt : app.get_options()) {
        const std::string name = opt->get_name();
        if (std::find(skip.begin(), skip.end(), name) != skip.end()) continue;
        std::string text;
        for (const auto& r : opt->results())
            text += r + '\x1f';
        values.emplace_back(name, text);
    }
    for (const CLI::App* group :
         app.get_subcommands([](const CLI::App* a) { return a->get_name().empty(); })) {
        const auto more = optionValues(*group, skip);
        values.insert(values.end(), more.begin(), more.end());
    }
    return values;
}

void checkFileOptions(const CLI::App& app, const CommonOptions& opts,
                      const std::vector<ExtraFile>& extra)
{
    std::vector<FileOption> outputs, inputs;
    markedFiles(app, true, outputs);
    markedFiles(app, false, inputs);
    for (const auto& e : extra) {
        if (e.path.empty() || e.path == "-") continue;
        (e.output ? outputs : inputs)
            .push_back({e.label, e.path, e.output ? e.format : std::nullopt});
    }
    if (const CLI::Option* config = app.get_option_no_throw("--config");
        config && config->count() > 0) {
        for (const auto& result : config->results())
            if (!result.empty() && result != "-") inputs.push_back({"--config", result, {}});
    }
    for (std::size_t i = 0; i < outputs.size(); ++i) {
        for (std::size_t j = i + 1; j < outputs.size(); ++j) {
            if (sameFile(outputs[i].path, outputs[j].path)) {
                throw UsageError(outputs[i].option + " " + outputs[i].path + " and " +
                                 outputs[j].option + " " + outputs[j].path +
                                 " are the same file; give each output its own name");
            }
        }
        for (const auto& in : inputs) {
            if (!sameFile(outputs[i].path, in.path)) continue;
            if (opts.inPlace && outputs[i].option == "-o" && in.option == "-i") continue;
            throw UsageError(outputs[i].option + " " + outputs[i].path + " is the input " +
                             in.option + " " + in.path +
                             "; writing it would destroy the input: give the output another name");
        }
    }
    for (const auto& out : outputs)
        if (out.format) checkOutputName(out.path, out.option, *out.format);
}

namespace {

/// @p text for a message: bytes that are not printable ASCII as \xNN, at most @p limit
/// characters (then "...").
std::string printable(const std::string& text, std::size_t limit = 40)
{
    std::string out;
    for (std::size_t i = 0; i < text.size(); ++i) {
        if (out.size() >= limit) return out + "...";
        const auto c = static_cast<unsigned char>(text[i]);
        if (c >= 0x20 && c < 0x7f) {
            out += char(c);
        } else {
            out += fmt::format("\\x{:02X}", unsigned(c));
        }
    }
    return out;
}

/// "(lo, hi]", "> 0", ">= 0", "< 1" or "" (no limit) for numberIn().
std::string rangeText(double lo, double hi, bool loOpen, bool hiOpen)
{
    const bool hasLo = std::isfinite(lo), hasHi = std::isfinite(hi);
    if (hasLo && hasHi) {
        return std::string(loOpen ? "(" : "[") + detail::numberText(lo) + ", " +
               detail::numberText(hi) + (hiOpen ? ")" : "]");
    }
    if (hasLo) return (loOpen ? "> " : ">= ") + detail::numberText(lo);
    if (hasHi) return (hiOpen ? "< " : "<= ") + detail::numberText(hi);
    return "";
}

} // namespace

CLI::Validator integerIn(std::int64_t lo, std::uint64_t hi)
{
    const std::string range = fmt::format("[{}, {}]", lo, hi);
    return CLI::Validator(
        [lo, hi, range](std::string& text) -> std::string {
            const std::string expected =
                "expected an integer in " + range + ", got " + printable(text);
            std::size_t i = 0;
            bool negative = false;
            if (i < text.size() && (text[i] == '+' || text[i] == '-')) negative = text[i++] == '-';
            if (i == text.size()) return expected;
            std::uint64_t magnitude = 0;
            for (; i < text.size(); ++i) {
                if (text[i] < '0' || text[i] > '9') return expected;
                const auto digit = std::uint64_t(text[i] - '0');
                if (magnitude > (UINT64_MAX - digit) / 10) return expected; // overflows
                magnitude = 10 * magnitude + digit;
            }
            if (negative && magnitude > 0) {
                // -magnitude >= lo, i.e. magnitude <= -lo (computed without overflow).
                if (lo >= 0 || magnitude - 1 > std::uint64_t(-(lo + 1))) return expected;
                text = "-" + std::to_string(magnitude);
            } else {
                if (magnitude > hi || (lo > 0 && magnitude < std::uint64_t(lo))) return expected;
                text = std::to_string(magnitude); // CLI11 would read "010" as octal
            }
            return "";
        },
        range, "nebula-integer");
}

CLI::Validator autoOrIntegerIn(int lo, int hi)
{
    const CLI::Validator number = integerIn(lo, hi);
    const std::string range = std::to_string(lo) + ", " + std::to_string(hi);
    return CLI::Validator(
        [number, range](std::string& s) {
            if (s == "auto") return std::string();
            std::string v = s;
            const std::string e = number(v);
            return e.empty() ? e : "expected auto or an integer in [" + range + "], got " + s;
        },
        "auto|" + std::to_string(lo) + ".." + std::to_string(hi));
}

CLI::Validator numberIn(double lo, double hi, bool loOpen, bool hiOpen)
{
    const std::string range = rangeText(lo, hi, loOpen, hiOpen);
    const std::string what = range.empty()                            ? "a finite number"
                             : std::isfinite(lo) && std::isfinite(hi) ? "a number in " + range
                                                                      : "a finite number " + range;
    return CLI::Validator(
        [=](std::string& text) -> std::string {
            const std::string expected = "expected " + what + ", got " + printable(text);
            char* end = nullptr;
            const double v = std::strtod(text.c_str(), &end);
            if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v)) {
                return expected;
            }
            const bool aboveLo = loOpen ? v > lo : v >= lo;
            const bool belowHi = hiOpen ? v < hi : v <= hi;
            return aboveLo && belowHi ? "" : expected;
        },
        // --help: CLI11's own words for the usual half-lines, else the range.
        !std::isfinite(hi) && lo == 0.0 ? (loOpen ? "POSITIVE" : "NONNEGATIVE") : range,
        "nebula-number");
}

CLI::Validator positive()
{
    return numberIn(0.0, INFINITY, true);
}

CLI::Validator nonNegative()
{
    return numberIn(0.0, INFINITY);
}

CLI::Validator finite()
{
    return numberIn(-INFINITY, INFINITY);
}

namespace {

bool hasValidator(CLI::Option& opt, const std::string& name)
{
    try {
        opt.get_validator(name);
        return true;
    } catch (const CLI::OptionNotFound&) {
        return false;
    }
}

/// A flag's value (--verbose=N, "v = N" in a config file): what CLI11's to_flag_value()
/// reads without throwing a std::exception past its parser (it calls std::stoll on anything it
/// does not know, which throws on "abc" and past 19 digits): true, false, on, off, yes, no,
/// enable, disable, one of "0123456789ftny+-", or a count of at most 9 digits.
CLI::Validator flagValue()
{
    return CLI::Validator(
        [](std::string& text) -> std::string {
            std::string v = text;
            for (char& c : v)
                c = char(std::tolower(static_cast<unsigned char>(c)));
            static const std::set<std::string> words{"",    "true", "false",  "on",     "off",
                                                     "yes", "no",   "enable", "disable"};
            if (words.count(v) || (v.size() == 1 && std::strchr("0123456789ftny+-", v[0]))) {
                return "";
            }
            const std::size_t i = (v[0] == '+' || v[0] == '-') ? 1 : 0;
            if (i < v.size() && v.size() - i <= 9 &&
                v.find_first_not_of("0123456789", i) == std::string::npos) {
                return "";
            }
            return "expected true, false or a count of at most 9 digits, got " + printable(text);
        },
        "", "nebula-flag");
}

} // namespace

void checkNumbers(CLI::App& app)
{
    for (CLI::Option* opt : app.get_options()) {
        if (opt->get_expected_min() == 0) { // a flag
            if (!hasValidator(*opt, "nebula-flag") && opt->get_name() != "--help" &&
                opt->get_name() != "--version") {
                opt->check(flagValue());
            }
            continue;
        }
        const std::string type = opt->get_type_name();
        if (type.rfind("FLOAT", 0) == 0) {
            if (!hasValidator(*opt, "nebula-number")) opt->check(finite());
        } else if (type.rfind("INT", 0) == 0 || type.rfind("UINT", 0) == 0) {
            if (!hasValidator(*opt, "nebula-integer")) {
                opt->check(type[0] == 'U'
                               ? integerIn(0, UINT64_MAX)
                               : integerIn(std::numeric_limits<int>::min(),
                                           std::uint64_t(std::numeric_limits<int>::max())));
            }
            // check() made it non-modifying; it must rewrite "010" as "10" for CLI11, which
            // would read it as octal.
            opt->get_validator("nebula-integer")->non_modifying(false);
        }
    }
    for (CLI::App* group : app.get_subcommands([](CLI::App* a) { return a->get_name().empty(); }))
        checkNumbers(*group);
}

void refuseSharedStream(const std::vector<std::pair<std::string, std::string>>& paths,
                        const std::string& stream)
{
    const std::pair<std::string, std::string>* first = nullptr;
    for (const auto& p : paths) {
        if (p.second != "-") continue;
        if (first) {
            throw UsageError(first->first + " - and " + p.first + " - both " +
                             (stream == "stdin" ? "read stdin" : "write stdout") +
                             ", which can carry only one of them; give one a file name");
        }
        first = &p;
    }
}

namespace {

std::string trimmed(const std::string& s)
{
    const auto b = s.find_first_not_of(" \t\r");
    if (b == std::string::npos) return "";
    const auto e = s.find_last_not_of(" \t\r");
    return s.substr(b, e - b + 1);
}

/// The option a config key names, as CLI11 looks it up ("res", "-o" style "o", "--res").
CLI::Option* configOption(CLI::App& app, const std::string& key)
{
    if (auto* o = app.get_option_no_throw("--" + key)) return o;
    if (key.size() == 1) {
        if (auto* o = app.get_option_no_throw("-" + key)) return o;
    }
    if (!key.empty() && key[0] == '-') return app.get_option_no_throw(key);
    return nullptr;
}

} // namespace

void checkConfigText(CLI::App& app, const std::string& text, const std::string& path,
                     const std::string& tool)
{
    std::istringstream in(text);
    const std::string where = "--config: " + path + ", line ";
    std::map<std::string, int> keyLines; // option name -> the line that set it
    std::string line;
    int number = 0;
    bool inArray = false; // inside a [multi-line, array] value
    while (std::getline(in, line)) {
        ++number;
        const std::string at = where + std::to_string(number) + ": ";
        for (std::size_t i = 0; i < line.size(); ++i) {
            const auto c = static_cast<unsigned char>(line[i]);
            if ((c < 0x20 && c != '\t' && c != '\r') || c == 0x7f) {
                throw UsageError(at + fmt::format("byte 0x{:02X} at column {} is not text; a "
                                                  "config file holds lines \"key = value\"",
                                                  unsigned(c), i + 1));
            }
        }
        const std::string text = trimmed(line);
        if (inArray) {
            if (!text.empty() && text.back() == ']') inArray = false;
            continue;
        }
        if (text.empty() || text[0] == '#' || text[0] == ';') continue;
        if (text.front() == '[') {
            if (text == "[default]" || text == "[[default]]") continue;
            throw UsageError(at + "section " + printable(text) + ": " + tool +
                             " has no sections (only [default]); give its options as "
                             "\"key = value\" lines at the top of the file");
        }
        const auto eq = text.find('=');
        std::string key = trimmed(text.substr(0, eq));
        if (key.size() >= 2 && (key.front() == '"' || key.front() == '\'') &&
            key.back() == key.front()) {
            key = key.substr(1, key.size() - 2);
        }
        CLI::Option* opt = key.empty() ? nullptr : configOption(app, key);
        const bool bareFlag = eq == std::string::npos && opt && opt->get_expected_min() == 0;
        if (eq == std::string::npos && !bareFlag) {
            throw UsageError(at + "expected \"key = value\", a [section] or a # comment, got \"" +
                             printable(text) + "\"");
        }
        if (!opt) {
            throw UsageError(at + "unknown option \"" + printable(key) +
                             "\" in the config file (not an option of " + tool + ")");
        }
        if (opt->get_name() == "--config") {
            throw UsageError(at + "a config file cannot name another config file");
        }
        if (const auto [first, fresh] = keyLines.emplace(opt->get_name(), number); !fresh) {
            throw UsageError(at + opt->get_name() + " is set again (line " +
                             std::to_string(first->second) +
                             " set it first); give each "
                             "option once");
        }
        if (eq != std::string::npos) {
            std::string value = trimmed(text.substr(eq + 1));
            if (value.empty()) {
                throw UsageError(at + "\"" + printable(key) + "\" has no value after '='");
            }
            if (value.front() == '[') {
                if (value.back() != ']') inArray = true;
                continue; // several values: CLI11 checks each
            }
            if (value.size() >= 2 && (value.front() == '"' || value.front() == '\'') &&
                value.back() == value.front()) {
                value = value.substr(1, value.size() - 2);
            }
            // The number checks, here where the line is known (CLI11 would name only the
            // option).
            for (const char* check : {"nebula-number", "nebula-integer"}) {
                try {
                    std::string copy = value;
                    const std::string error = (*opt->get_validator(check))(copy);
                    if (!error.empty()) throw UsageError(at + opt->get_name() + ": " + error);
                } catch (const CLI::OptionNotFound&) {
                }
            }
        }
    }
    if (inArray) {
        throw UsageError(where + std::to_string(number) +
                         ": the array opened with '[' is not closed");
    }
}

namespace {

/// A config file's text in an anonymous memory file, for CLI11 to read by name
/// (/proc/self/fd/N) after checkConfigText() has checked it: CLI11 reopens the file it is
/// given, which for a pipe would find it drained (or wait for a writer that is gone).
class ConfigCopy
{
public:
    ConfigCopy(const std::string& text, const std::string& source)
    {
        fd_ = int(::memfd_create("nebula-config", MFD_CLOEXEC));
        if (fd_ < 0) {
            throw Error("--config " + source + ": cannot make a memory copy (" +
                        std::strerror(errno) + ")");
        }
        std::size_t done = 0;
        while (done < text.size()) {
            const ssize_t n = ::write(fd_, text.data() + done, text.size() - done);
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) {
                ::close(fd_);
                throw Error("--config " + source + ": cannot make a memory copy (" +
                            std::strerror(errno) + ")");
            }
            done += std::size_t(n);
        }
    }
    ConfigCopy(const ConfigCopy&) = delete;
    ConfigCopy& operator=(const ConfigCopy&) = delete;
    ~ConfigCopy() { ::close(fd_); }
    std::string path() const { return "/proc/self/fd/" + std::to_string(fd_); }

private:
    int fd_ = -1;
};

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

std::optional<std::string> hugePageTunables(const char* tunables, const std::string& thpMode)
{
    const std::string current = tunables ? tunables : "";
    if (current.find("glibc.malloc.hugetlb") != std::string::npos) return std::nullopt;
    if (thpMode.find("[madvise]") == std::string::npos) return std::nullopt;
    return current.empty() ? "glibc.malloc.hugetlb=1" : current + ":glibc.malloc.hugetlb=1";
}

namespace {

/// Runs this program again, once, with glibc's malloc on transparent huge pages
/// (hugePageTunables()). OpenVDB's trees are millions of small blocks from malloc; on 4 KiB
/// pages every 4 KiB costs a page fault, which is dear on virtual machines: a 32x18 frame of
/// the 128^3 example's scattered.vdb, nearly all reading, takes 0.8 s this way and 1.4-1.6 s
/// without, here; the second start costs about 60 ms. Nothing has been read yet (stdin is
/// untouched) and the process keeps its descriptors, arguments and environment. Only for the
/// program named @p tool; not for --help and --version, nor under AddressSanitizer (its own
/// allocator); an exec that fails (no /proc) leaves the program running as it is.
void useHugePageMalloc(const std::string& tool, int argc, char** argv)
{
#if defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 35)) &&          \
    !defined(__SANITIZE_ADDRESS__)
    for (int i = 1; i < argc; ++i) {
        const std::string_view a(argv[i]);
        if (a == "-h" || a == "--help" || a == "--version") return;
    }
    // Only the tool itself (a program that calls run() for another, as the tests do, is not
    // started again).
    std::error_code ec;
    if (std::filesystem::read_symlink("/proc/self/exe", ec).filename() != tool || ec) return;
    std::ifstream thp("/sys/kernel/mm/transparent_hugepage/enabled");
    std::string mode;
    std::getline(thp, mode);
    const char* tunables = std::getenv("GLIBC_TUNABLES");
    const std::string before = tunables ? tunables : "";
    const auto value = hugePageTunables(tunables, mode);
    if (!value || ::setenv("GLIBC_TUNABLES", value->c_str(), 1) != 0) return;
    ::execv("/proc/self/exe", argv);
    // Still here: the exec failed. Carry on, and leave the environment as it was.
    if (tunables) {
        ::setenv("GLIBC_TUNABLES", before.c_str(), 1);
    } else {
        ::unsetenv("GLIBC_TUNABLES");
    }
#else
    (void)tool;
    (void)argc;
    (void)argv;
#endif
}

} // namespace

namespace {

/// ", reading -i X and writing -o Y" for an out-of-memory message: the files it was about.
std::string memoryContext(const CommonOptions& opts)
{
    std::string s;
    if (!opts.input.empty()) s += ", reading -i " + detail::printable(opts.input, 200);
    if (!opts.output.empty())
        s += (s.empty() ? ", writing -o " : " and writing -o ") +
             detail::printable(opts.output, 200);
    return s;
}

} // namespace

int run(CLI::App& app, const std::string& tool, CommonOptions& opts, int argc, char** argv,
        const std::function<void(Run&)>& body)
{
    // The build's man page and completion (cli/manual.h), from the options as defined; the
    // man page has the whole description, --help its purpose and first examples.
    const std::string description = app.get_description();
    if (argc == 2 && (std::string_view(argv[1]) == "--man" ||
                      std::string_view(argv[1]) == "--bash-completion")) {
        std::cout << (std::string_view(argv[1]) == "--man" ? manPage(app, tool, description)
                                                           : bashCompletion(app, tool));
        return std::cout.flush() ? 0 : 1;
    }
    app.description(shortHelp(description, tool));
    useHugePageMalloc(tool, argc, argv);
    try {
        checkNumbers(app);
        // The config file is read once (a pipe or /dev/stdin as the stream it is, with a size
        // limit), checked line by line, and CLI11 reads that same text from a memory file.
        std::vector<std::string> args(argv, argv + argc);
        std::string configPath;
        std::optional<ConfigCopy> copy;
        for (std::size_t i = 1; i < args.size(); ++i) {
            std::string* value = nullptr;
            std::string prefix;
            if (args[i] == "--config" && i + 1 < args.size()) {
                value = &args[++i];
            } else if (args[i].rfind("--config=", 0) == 0) {
                prefix = "--config=";
                value = &args[i];
            }
            if (!value) continue;
            if (copy) throw UsageError("--config is given twice; give one config file");
            configPath = value->substr(prefix.size());
            InputSpec spec;
            spec.option = "--config";
            spec.format = "a config file";
            spec.head = textHead("--config: " + configPath);
            std::string text;
            try {
                text = readInput(configPath, spec);
            } catch (const UsageError&) {
                throw;
            } catch (const Error& e) {
                throw UsageError(e.what());
            }
            checkConfigText(app, text, configPath, tool);
            copy.emplace(text, configPath);
            *value = prefix + copy->path();
        }
        std::vector<char*> ptrs;
        for (auto& a : args)
            ptrs.push_back(a.data());
        app.parse(int(ptrs.size()), ptrs.data());
        if (copy) {
            // The option names the user's file again (checkFileOptions(), messages).
            auto* config = app.get_option("--config");
            config->clear();
            config->add_result(configPath);
        }
    } catch (const UsageError& e) { // from an option's callback (addVec3) or checkConfigText
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
        checkFileOptions(app, opts);
        setWriteThrough(opts.writeThrough);
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
    } catch (const std::bad_alloc&) {
        std::cerr << tool << ": error: out of memory (an allocation failed" << memoryContext(opts)
                  << "); try a smaller size, resolution or number of levels, or fewer threads\n";
        return 1;
    } catch (const std::length_error&) { // a container asked for more than it can ever hold
        std::cerr << tool << ": error: out of memory (a size beyond any machine's memory"
                  << memoryContext(opts)
                  << "); try a smaller size, resolution, box or number of levels\n";
        return 1;
    } catch (const std::exception& e) {
        std::cerr << tool << ": error: " << e.what() << "\n";
        return 1;
    }
}

} // namespace cli

} // namespace nebula
