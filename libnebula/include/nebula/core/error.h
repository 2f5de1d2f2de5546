// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file error.h
/// The exceptions libnebula throws. Tools turn Error into "tool: error: ..." and exit 1;
/// Cancelled ends work a caller asked to stop (Run::setCancel()) and is never an error.

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

/// Thrown by long work (a frame's rows) when its Run's cancel flag is set: the caller that set
/// it (nebview, when a newer camera arrives) catches it and drops the partial result.
class Cancelled : public std::exception
{
public:
    const char* what() const noexcept override { return "cancelled"; }
};

} // namespace nebula
