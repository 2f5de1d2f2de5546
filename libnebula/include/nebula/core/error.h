#pragma once
/// @file error.h
/// The one exception type libnebula throws. Tools turn it into "tool: error: ..." and exit 1.

#include <stdexcept>
#include <string>

namespace nebula {

/// A runtime or data error. The message names the file, grid or option, what was expected
/// and what was found, e.g. `cloud.vdb: grid "density" is a Vec3fGrid, expected a FloatGrid`.
class Error : public std::runtime_error
{
public:
    explicit Error(const std::string& what) : std::runtime_error(what) {}
};

/// A usage error (bad option value): tools exit with code 2.
class UsageError : public Error
{
public:
    explicit UsageError(const std::string& what) : Error(what) {}
};

} // namespace nebula
