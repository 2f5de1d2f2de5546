// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file file_format.h
/// The file formats nebula writes and the names they go by (docs/failures.md, "Outputs that
/// say another format"): every writer checks its output's name with checkOutputName() before
/// it writes, and the command line checks every output option with it before any work
/// (cli::outputFile()), so a VDB is never written under `.fits` nor a FITS file under `.npy`.

#include <optional>
#include <string>
#include <vector>

namespace nebula {

enum class FileFormat { Vdb, Exr, Png, Fits, Npy, Hdf5, Csv, Json };

/// "VDB", "EXR", "PNG", "FITS", "NumPy .npy", "HDF5", "CSV", "JSON".
const char* formatName(FileFormat format);

/// The name endings of @p format, lower case, the first the usual one: {".vdb"},
/// {".fits", ".fit", ".fts"} (nebula writes no gzip-compressed FITS), {".h5", ".hdf5", ".he5"}.
const std::vector<std::string>& formatExtensions(FileFormat format);

/// The format whose ending @p path has (case-insensitive), or nullopt.
std::optional<FileFormat> formatOfName(const std::string& path);

/// Throws UsageError unless @p path ends in one of @p format's endings (case-insensitive).
/// "-" (stdout) and a name that exists and is not a regular file or a link to one (a FIFO, a
/// device, /dev/fd/N: --write-through) pass, as they have no name to keep. @p option names the
/// output in the message ("-o", "--fits"), which names both formats where the ending is
/// another format's: "-o out.fits: the name says FITS, but this output is VDB; name it *.vdb".
void checkOutputName(const std::string& path, const std::string& option, FileFormat format);

} // namespace nebula
