// Builds without MPI (INSID_WITH_MPI off or no MPI found): single process, shards and merge
// only; an MPI launch is refused rather than running the whole campaign once per process.
#include <memory>
#include <stdexcept>
#include <string>

#include "bench/cluster.h"

namespace insid::campaign {

bool built_with_mpi() { return false; }

std::unique_ptr<Cluster> join_mpi_launch(const std::string& /*command*/) {
  const int n = launched_world_size();
  if (n > 1)
    throw std::runtime_error(
        "this insid was built without MPI (INSID_WITH_MPI=OFF or no MPI found) but was launched "
        "as one of " +
        std::to_string(n) +
        " MPI processes, each of which would run the whole campaign. Rebuild with MPI "
        "(libopenmpi-dev), or run the processes as shards with --shard i/N.");
  return nullptr;
}

}  // namespace insid::campaign
