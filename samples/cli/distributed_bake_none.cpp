// distributedBake in a build without MPI (find_package(MPI) found none): mpirun would start N
// full bakes writing the same file, so the run is refused with the way that works without MPI.
#include <cstdio>

#include "cli/shard_commands.h"

namespace shrefract::cli {

int distributedBake(const bake::Scene&, bake::BakeOptions, const std::string& output, bool) {
  std::fprintf(stderr,
               "shrefract bake: started by mpirun with %d processes, but this build has no MPI; bake each "
               "shard with --shard I/N and join them with `shrefract merge` (%s not written)\n",
               launchedRanks(), output.c_str());
  return 1;
}

}  // namespace shrefract::cli
