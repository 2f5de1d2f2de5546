// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file process_ranks.h
/// The MPI ranks a tool was started as (nebscatter under mpirun or srun; README,
/// "nebscatter over MPI"). Built into the small target nebula_mpi, which only the tools that
/// share work over ranks link, with Debian's OpenMPI where CMake found it
/// (NEBULA_WITH_MPI); without it every process is alone, and one started as several
/// processes says so instead of computing and writing the whole result N times.

#include "nebula/core/ranks.h"

#include <memory>
#include <string>
#include <vector>

namespace nebula::cli {

/// The ranks this process belongs to. Where the environment says it was started as one of
/// several processes (OpenMPI's mpirun: OMPI_COMM_WORLD_SIZE; PMI or PMIx launchers:
/// PMI_SIZE, PMIX_RANK; srun: SLURM_STEP_NUM_TASKS), MPI is initialised (threads funnelled:
/// only the calling thread talks to MPI) and its world is the group; else the single
/// process. Throws Error when MPI cannot start (naming @p tool), or when the environment
/// gives several processes but they cannot be joined: a build without MPI, or MPI seeing one
/// process of a multi-task srun step (srun without an MPI plugin: use mpirun, or srun --mpi=pmix).
std::unique_ptr<Ranks> processRanks(const std::string& tool);

/// One part of what every rank must agree on: an option's value, an input's contents.
struct RunPart
{
    std::string what;  ///< for the message: "--packets", "the input -i lit.vdb"
    std::string value; ///< its text (the option's values, the input's checksums)
};

/// Checks, before any work, that every rank of @p ranks runs the same computation: rank 0's
/// digest of each of @p parts goes to every rank, and where any rank's differs (ranks started
/// with another --packets, --seed or input file, or another version of the tool) every rank
/// throws the same Error naming the first part that differs and the rank; finishRanks() then
/// stops the job. Nothing is sent with one rank.
void requireSameRun(const Ranks& ranks, const std::vector<RunPart>& parts);

/// Ends @p ranks with the tool's exit code @p rc and returns it: MPI_Finalize when rc is 0;
/// otherwise, with more than one rank, MPI_Abort(rc), which stops every rank (one rank's
/// error must not leave the others waiting in a sum; the launcher exits non-zero and no
/// rank writes). A null @p ranks (the tool failed before asking) does nothing.
int finishRanks(std::unique_ptr<Ranks>& ranks, int rc);

} // namespace nebula::cli
