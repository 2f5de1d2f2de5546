#pragma once
/// @file atomic_file.h
/// Every output file (VDB, EXR, PNG) is written through AtomicFile: the data goes to a
/// temporary name in the same folder, commit() renames it over the target, and the
/// destructor removes the temporary if commit() was never reached. A failed or interrupted
/// tool therefore never leaves a half-written output behind (DESIGN §1).

#include <string>

namespace nebula {

class AtomicFile
{
public:
    /// Creates the temporary file next to @p path. Throws Error if the folder is not writable.
    explicit AtomicFile(const std::string& path);
    ~AtomicFile();
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    /// The temporary path to write to.
    const std::string& tmpPath() const { return mTmpPath; }
    /// The final path.
    const std::string& path() const { return mPath; }
    /// Renames the temporary file over the final path. Throws Error on failure.
    void commit();

private:
    std::string mPath;
    std::string mTmpPath;
    bool mCommitted = false;
};

/// Throws Error unless the folder that would hold @p path exists and is writable.
void checkOutputWritable(const std::string& path, const std::string& what);

} // namespace nebula
