// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file atomic_file.h
/// Every output file (VDB, EXR, PNG, JSON) is written through AtomicFile, so that nothing is
/// lost and nothing half-written is left behind (DESIGN §1, README "Failure behaviour"):
/// - the data goes to a temporary "<name>.tmp.<pid>.XXXXXX" in the target's folder, through
///   stream(), which checks every write;
/// - finish() flushes, fsyncs and closes it, checking each step; commit() renames it over the
///   target and fsyncs the folder; commitAll() does that for several outputs, all or none;
/// - any failure throws Error naming the file and the OS error, and the target keeps its old
///   contents; the destructor, SIGINT, SIGTERM and SIGHUP remove an uncommitted temporary,
///   and the next AtomicFile of the same name removes temporaries whose writer has died
///   (killed with SIGKILL, or by a power cut);
/// - a target that is not a regular file (a FIFO, a device, a symlink, a folder) is refused
///   unless setWriteThrough(true) (the tools' --write-through): then FIFOs and devices are
///   written directly, and a symlink's target file is replaced atomically.

#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

namespace nebula {

class AtomicFile
{
public:
    /// Checks the target, removes stale temporaries of its name and creates the temporary.
    /// Throws UsageError for a target that is not a regular file (see above), Error if the
    /// folder is not writable.
    explicit AtomicFile(const std::string& path);
    ~AtomicFile();
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    /// Where the data goes: every write is checked; seekable for regular files (VDB and EXR
    /// writers seek back to fill in offsets). A failed write sets badbit and is reported by
    /// finish() with its OS error.
    std::ostream& stream();
    /// The temporary path being written ("" when writing through to a FIFO or device).
    const std::string& tmpPath() const { return mTmpPath; }
    /// The final path.
    const std::string& path() const { return mPath; }
    /// Flushes, fsyncs and closes the temporary, checking every step; throws Error naming the
    /// file and the OS error (e.g. "No space left on device"). Idempotent.
    void finish();
    /// finish(), then renames the temporary over the target and fsyncs the folder.
    void commit();

    /// The name pattern of this file's temporaries: "<path>.tmp.<pid>.XXXXXX".
    static std::string tmpPrefix(const std::string& path);

private:
    friend void commitAll(const std::vector<AtomicFile*>& files);
    void rename();
    void fail(const std::string& what, int err);

    struct Impl;
    std::unique_ptr<Impl> mImpl;
    std::string mPath;    ///< the target as given
    std::string mTarget;  ///< the file replaced: mPath, or a symlink's resolved target
    std::string mTmpPath; ///< "" when writing through
    bool mFinished = false;
    bool mCommitted = false;
};

/// Commits several outputs all or none: finishes every one first (any write error throws
/// before a single target changed), then renames them in order; should a rename fail, the
/// targets already replaced get their old contents back. Throws Error.
void commitAll(const std::vector<AtomicFile*>& files);

/// Write through FIFOs, devices and symlinks instead of refusing them (--write-through).
void setWriteThrough(bool enabled);

/// Throws Error unless the folder that would hold @p path exists and is writable and @p path
/// is not a folder; @p what names the output ("EXR", "phase table").
void checkOutputWritable(const std::string& path, const std::string& what);

/// What AtomicFile's constructor will refuse, checked before any work (an output written
/// long after the start, such as nebview's --path-out): checkOutputWritable(), and a target
/// that is a FIFO, a device, a socket or a symbolic link is a UsageError naming @p what
/// unless setWriteThrough(true).
void checkOutputTarget(const std::string& path, const std::string& what);

/// Removes the temporaries "<path>.tmp.<pid>.XXXXXX" whose writer is gone: no process has that
/// pid, or the process that has it started after the temporary was last written. Returns how
/// many were removed. AtomicFile's constructor calls it.
int removeStaleTemporaries(const std::string& path);

} // namespace nebula
