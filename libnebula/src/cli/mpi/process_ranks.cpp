// SPDX-License-Identifier: Apache-2.0
/// @file process_ranks.cpp
/// cli/process_ranks.h: MPI ranks where the build has MPI (NEBULA_HAVE_MPI), the single
/// process otherwise. Compiled into nebula_mpi, not nebula_cli: only the tools that share
/// work over ranks link MPI.

#include "nebula/cli/process_ranks.h"

#include "nebula/core/error.h"

#include <algorithm>
#include <climits>
#include <cstdlib>
#include <string>
#include <vector>

#ifdef NEBULA_HAVE_MPI
#include <mpi.h>
#endif

namespace nebula::cli {

namespace {

/// A positive integer environment variable, or 0.
long envCount(const char* name)
{
    const char* v = std::getenv(name);
    if (!v || !*v) return 0;
    char* end = nullptr;
    const long n = std::strtol(v, &end, 10);
    return end && *end == '\0' && n > 0 ? n : 0;
}

/// How many processes the launcher says it started (1: none or one), and which variable.
long launchedProcesses(std::string& by)
{
    for (const char* name :
         {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE", "SLURM_STEP_NUM_TASKS"}) {
        if (const long n = envCount(name); n > 1) {
            by = name;
            return n;
        }
    }
    return 1;
}

#ifdef NEBULA_HAVE_MPI
/// Whether an MPI launcher started this process (even as the only one).
bool launchedByMpi()
{
    for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_RANK", "PMIX_RANK"})
        if (std::getenv(name)) return true;
    return false;
}

/// MPI_COMM_WORLD; MPI initialised by the constructor, finalised by finishRanks().
class MpiRanks final : public Ranks
{
public:
    explicit MpiRanks(const std::string& tool)
    {
        int provided = 0;
        if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS)
            throw Error(tool + " could not start MPI (MPI_Init_thread failed)");
        MPI_Comm_rank(MPI_COMM_WORLD, &mRank);
        MPI_Comm_size(MPI_COMM_WORLD, &mSize);
        // Errors end the run (MPI_ERRORS_ARE_FATAL, the default): a sum that fails on one
        // rank must not leave the others waiting.
    }
    int rank() const override { return mRank; }
    int size() const override { return mSize; }
    void sumToRoot(std::int64_t* data, std::size_t n) const override { sum(data, n, MPI_INT64_T); }
    void sumToRoot(std::uint64_t* data, std::size_t n) const override
    {
        sum(data, n, MPI_UINT64_T);
    }

    std::pair<std::size_t, int>
    firstDisagreement(const std::vector<std::uint64_t>& digests) const override
    {
        if (mSize == 1) return {digests.size(), -1};
        // Rank 0's count and digests to every rank; each finds its first difference; the
        // smallest (index, rank) pair wins everywhere.
        std::uint64_t count = digests.size();
        MPI_Bcast(&count, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
        std::vector<std::uint64_t> root(static_cast<std::size_t>(count)); // tens of parts
        if (mRank == 0) root = digests;
        MPI_Bcast(root.data(), int(root.size()), MPI_UINT64_T, 0, MPI_COMM_WORLD);
        std::size_t first = std::min(root.size(), digests.size());
        for (std::size_t i = 0; i < first; ++i) {
            if (root[i] != digests[i]) {
                first = i;
                break;
            }
        }
        const bool same = first == digests.size() && root.size() == digests.size();
        struct
        {
            int index, rank;
        } mine{same ? INT_MAX : int(std::min<std::size_t>(first, INT_MAX - 1)), mRank}, lowest{};
        MPI_Allreduce(&mine, &lowest, 1, MPI_2INT, MPI_MINLOC, MPI_COMM_WORLD);
        if (lowest.index == INT_MAX) return {digests.size(), -1};
        return {std::size_t(lowest.index), lowest.rank};
    }

private:
    template <typename T> void sum(T* data, std::size_t n, MPI_Datatype type) const
    {
        if (mSize == 1) return;
        // MPI counts are int: pieces of at most 2^27 elements (1 GiB).
        constexpr std::size_t PIECE = std::size_t(1) << 27;
        for (std::size_t at = 0; at < n; at += PIECE) {
            const int count = int(std::min(PIECE, n - at));
            if (mRank == 0) {
                MPI_Reduce(MPI_IN_PLACE, data + at, count, type, MPI_SUM, 0, MPI_COMM_WORLD);
            } else {
                MPI_Reduce(data + at, nullptr, count, type, MPI_SUM, 0, MPI_COMM_WORLD);
            }
        }
    }

    int mRank = 0, mSize = 1;
};
#endif

} // namespace

std::unique_ptr<Ranks> processRanks(const std::string& tool)
{
    std::string by;
    const long launched = launchedProcesses(by);
#ifdef NEBULA_HAVE_MPI
    if (launched > 1 || launchedByMpi()) {
        auto ranks = std::make_unique<MpiRanks>(tool);
        if (ranks->size() == 1 && launched > 1) {
            // Each of the launched processes is alone: srun without an MPI plugin.
            ranks.reset();
            MPI_Finalize();
            throw Error("started as " + std::to_string(launched) + " processes (" + by +
                        "), but MPI sees this one alone, so each would compute and write the "
                        "whole result: start it with mpirun, or srun --mpi=pmix where Slurm "
                        "has the PMIx plugin (srun --mpi=list)");
        }
        return ranks;
    }
#else
    if (launched > 1) {
        throw Error("started as " + std::to_string(launched) + " processes (" + by +
                    "), but this build of " + tool +
                    " has no MPI, so each would compute and write the whole result: rebuild "
                    "with libopenmpi-dev installed (CMake finds it; -DNEBULA_WITH_MPI=ON), or "
                    "run one process");
    }
#endif
    return std::make_unique<Ranks>();
}

namespace {

/// FNV-1a, 64 bits: the same text gives the same digest on every rank.
std::uint64_t textDigest(const std::string& text)
{
    std::uint64_t h = 14695981039346656037ull;
    for (const unsigned char c : text) {
        h ^= c;
        h *= 1099511628211ull;
    }
    return h;
}

} // namespace

void requireSameRun(const Ranks& ranks, const std::vector<RunPart>& parts)
{
    std::vector<std::uint64_t> digests;
    digests.reserve(parts.size());
    for (const auto& p : parts)
        digests.push_back(textDigest(p.what + '\x1f' + p.value));
    const auto [index, rank] = ranks.firstDisagreement(digests);
    if (rank < 0) return;
    const std::string what = index < parts.size() ? parts[index].what : "the options";
    throw Error("MPI rank " + std::to_string(rank) + " of " + std::to_string(ranks.size()) +
                " differs from rank 0 in " + what +
                ": every rank must run the same command on the same input, or the summed "
                "field would be wrong; nothing was computed");
}

int finishRanks(std::unique_ptr<Ranks>& ranks, int rc)
{
    if (!ranks) return rc;
#ifdef NEBULA_HAVE_MPI
    if (dynamic_cast<MpiRanks*>(ranks.get())) {
        if (rc != 0 && ranks->size() > 1) MPI_Abort(MPI_COMM_WORLD, rc);
        ranks.reset();
        MPI_Finalize();
    }
#endif
    ranks.reset();
    return rc;
}

} // namespace nebula::cli
