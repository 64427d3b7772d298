// The processes of one MPI launch (`mpirun -np N insid bench ...`) sharing a campaign.
// campaign.cc sees only this interface; cluster_mpi.cc implements it with Open MPI (built when
// INSID_WITH_MPI is on), cluster_none.cc stands in without MPI and refuses an MPI launch.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace insid::campaign {

/// One unit of work: indices into the campaign's deterministic run list, with a leading flag
/// (see campaign.cc). Plain integers so that they travel as one MPI message.
using WorkUnit = std::vector<std::int64_t>;

class Cluster {
 public:
  virtual ~Cluster() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;
  /// The command this launch runs ("insid bench"), to start a rank's messages.
  virtual const std::string& command() const = 0;
  /// Rank 0's `text` on every rank (collective).
  virtual std::string broadcast(const std::string& text) = 0;
  /// The sum of `value` over the ranks, on every rank (collective).
  virtual std::int64_t sum(std::int64_t value) = 0;
  /// Every rank's `value`, by rank, on every rank (collective).
  virtual std::vector<std::int64_t> gather(std::int64_t value) = 0;
  /// Deal rank 0's `units` (ignored on the other ranks) out one at a time, in order, to
  /// whichever rank asks next, rank 0 included, and call `work` with each unit on the rank
  /// that got it: a rank that finishes early takes more. Collective; returns on every rank once
  /// every unit is done. `work` must not throw (a rank that throws aborts the whole launch).
  virtual void deal(const std::vector<WorkUnit>& units,
                    const std::function<void(const WorkUnit&)>& work) = 0;
};

/// Number of processes the launcher started this one among (Open MPI's OMPI_COMM_WORLD_SIZE,
/// or PMI_SIZE from MPICH-style launchers); 1 when not launched by mpirun.
int launched_world_size();

/// Join the MPI launch this process is part of: nullptr when it is the only process. Throws
/// std::runtime_error, naming the way out, when this build has no MPI but was launched as one
/// of several processes (each would otherwise run the whole campaign). The returned object
/// finalizes MPI when destroyed. `command` ("insid bench") starts a rank's error message.
std::unique_ptr<Cluster> join_mpi_launch(const std::string& command);

/// Whether this build can join an MPI launch.
bool built_with_mpi();

}  // namespace insid::campaign
