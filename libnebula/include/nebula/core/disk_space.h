// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file disk_space.h
/// The room left on the file system an output goes to, so that a writer whose size is known
/// before it starts (nebexport's dense cubes) can refuse before its first byte, as
/// requireMemory() does before an allocation.

#include <cstdint>
#include <optional>
#include <string>

namespace nebula {

/// The bytes an unprivileged writer may still write on the file system that would hold @p path
/// (statvfs of its folder, where AtomicFile puts the temporary; of the resolved target's folder
/// for a symlink); nullopt where no file system fills up or none can be asked: "-" (stdout), a
/// FIFO or a device, a folder that does not exist (the writer then refuses it by name).
std::optional<std::uint64_t> freeDiskSpace(const std::string& path);

} // namespace nebula
