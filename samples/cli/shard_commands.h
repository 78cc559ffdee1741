// Sharded and distributed bakes in the tool (bake/include/shrefract/bake/shard.h):
// `bake --shard I/N` writes a part, `merge` joins parts, `mpirun -np N shrefract bake` does both
// over MPI (docs/performance.md, "Sharded and distributed bakes").
#pragma once

#include <shrefract/bake/bake.h>
#include <shrefract/bake/shard.h>
#include <shrefract/field.h>

#include <string>

#include "cli/progress.h"

namespace shrefract::cli {

// Writes `field` to `output` (atomically) and prints its summary (text or JSON) on stdout.
// Returns the exit code; a failure prints one line naming the file.
int writeFieldAndSummary(const Field& field, const std::string& output, bool json);

// `bake --shard`: bakes one shard of `scene` and writes the part to `output`. Returns the exit code.
// `progress` is the one options.progress draws; it is finished before anything else is printed.
int bakeShardToFile(const bake::Scene& scene, const bake::BakeOptions& options, bake::Shard shard,
                    const std::string& output, bool json, Progress& progress);

// Processes of this MPI job as the launcher's environment says (Open MPI, MPICH, MVAPICH), 1 when
// not launched by mpirun: read before MPI_Init, so that a build without MPI can refuse such a run.
int launchedRanks();

// The bake across the ranks of an MPI job: each rank bakes its shard (multi-threaded), rank 0
// gathers the parts, merges them, writes `output` and draws the progress of all ranks. A rank
// that fails prints one line and ends the job (MPI_Abort). Without MPI in this build: one line,
// exit 1. Returns the exit code.
int distributedBake(const bake::Scene& scene, bake::BakeOptions options, const std::string& output, bool json);

}  // namespace shrefract::cli
