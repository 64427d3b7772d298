// The MPI cluster (Open MPI): rank 0 deals work units from a dispatcher thread while its main
// thread computes too (a machine of 2 cores cannot spare one for a pure master).
//
// Threading: MPI is initialised with MPI_THREAD_SERIALIZED; while `deal` runs, only rank 0's
// dispatcher thread calls MPI there (the main thread takes units from the same queue through a
// mutex), and the main thread's collectives happen before the dispatcher starts or after it is
// joined. Progress: Open MPI progresses messages only inside MPI calls, so the dispatcher polls
// (MPI_Iprobe, then sleeps 1 ms): a worker's request waits at most about a millisecond, even
// while rank 0's main thread computes, and the dispatcher costs no core. Waits for a unit or
// for the last rank to finish poll the same way instead of blocking, because Open MPI's
// blocking calls spin and would take a core from the ranks still computing.
#include <mpi.h>

#include <atomic>
#include <chrono>
#include <iostream>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>

#include "bench/cluster.h"

namespace insid::campaign {
namespace {

constexpr int kTagRequest = 1;  // worker -> rank 0: give me a unit (empty message)
constexpr int kTagUnit = 2;     // rank 0 -> worker: a unit, or an empty one for "no more work"
constexpr auto kPoll = std::chrono::milliseconds(1);

// Wait for a non-blocking request by polling (see the file comment).
void wait_politely(MPI_Request& request) {
  for (int done = 0;;) {
    MPI_Test(&request, &done, MPI_STATUS_IGNORE);
    if (done) return;
    std::this_thread::sleep_for(kPoll);
  }
}

class MpiCluster final : public Cluster {
 public:
  explicit MpiCluster(std::string command) : command_(std::move(command)) {
    int provided = 0;
    MPI_Init_thread(nullptr, nullptr, MPI_THREAD_SERIALIZED, &provided);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
    if (provided < MPI_THREAD_SERIALIZED) {
      MPI_Finalize();
      throw std::runtime_error("the MPI library provides thread level " + std::to_string(provided) +
                               ", insid needs MPI_THREAD_SERIALIZED (" +
                               std::to_string(MPI_THREAD_SERIALIZED) + ")");
    }
  }
  ~MpiCluster() override { MPI_Finalize(); }

  int rank() const override { return rank_; }
  int size() const override { return size_; }
  const std::string& command() const override { return command_; }

  std::string broadcast(const std::string& text) override {
    long long length = rank_ == 0 ? static_cast<long long>(text.size()) : 0;
    MPI_Bcast(&length, 1, MPI_LONG_LONG, 0, MPI_COMM_WORLD);
    std::string out = rank_ == 0 ? text : std::string(static_cast<std::size_t>(length), '\0');
    if (length > 0) MPI_Bcast(out.data(), static_cast<int>(length), MPI_CHAR, 0, MPI_COMM_WORLD);
    return out;
  }

  std::int64_t sum(std::int64_t value) override {
    std::int64_t total = 0;
    MPI_Allreduce(&value, &total, 1, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
    return total;
  }

  std::vector<std::int64_t> gather(std::int64_t value) override {
    std::vector<std::int64_t> values(static_cast<std::size_t>(size_));
    MPI_Allgather(&value, 1, MPI_INT64_T, values.data(), 1, MPI_INT64_T, MPI_COMM_WORLD);
    return values;
  }

  void deal(const std::vector<WorkUnit>& units,
            const std::function<void(const WorkUnit&)>& work) override {
    if (rank_ == 0)
      deal_as_root(units, work);
    else
      deal_as_worker(work);
    // Everyone waits here for the last unit anywhere.
    MPI_Request barrier;
    MPI_Ibarrier(MPI_COMM_WORLD, &barrier);
    wait_politely(barrier);
  }

 private:
  void run_or_abort(const std::function<void(const WorkUnit&)>& work, const WorkUnit& unit) {
    try {
      work(unit);
    } catch (const std::exception& e) {
      std::cerr << command_ << ": error on MPI rank " << rank_ << ": " << e.what() << "\n";
      MPI_Abort(MPI_COMM_WORLD, 1);
    }
  }

  void deal_as_root(const std::vector<WorkUnit>& units,
                    const std::function<void(const WorkUnit&)>& work) {
    std::mutex mutex;
    std::size_t next = 0;
    auto take = [&]() -> const WorkUnit* {
      std::lock_guard<std::mutex> lock(mutex);
      return next < units.size() ? &units[next++] : nullptr;
    };
    std::thread dispatcher([&] {
      const WorkUnit no_more_work;
      for (int finished_workers = 0; finished_workers < size_ - 1;) {
        int pending = 0;
        MPI_Status status;
        MPI_Iprobe(MPI_ANY_SOURCE, kTagRequest, MPI_COMM_WORLD, &pending, &status);
        if (!pending) {
          std::this_thread::sleep_for(kPoll);
          continue;
        }
        MPI_Recv(nullptr, 0, MPI_INT, status.MPI_SOURCE, kTagRequest, MPI_COMM_WORLD,
                 MPI_STATUS_IGNORE);
        const WorkUnit* unit = take();
        if (unit == nullptr) {
          unit = &no_more_work;
          ++finished_workers;
        }
        MPI_Send(unit->data(), static_cast<int>(unit->size()), MPI_INT64_T, status.MPI_SOURCE,
                 kTagUnit, MPI_COMM_WORLD);
      }
    });
    while (const WorkUnit* unit = take()) run_or_abort(work, *unit);
    dispatcher.join();
  }

  void deal_as_worker(const std::function<void(const WorkUnit&)>& work) {
    for (;;) {
      MPI_Send(nullptr, 0, MPI_INT, 0, kTagRequest, MPI_COMM_WORLD);
      MPI_Status status;
      for (int arrived = 0; !arrived;) {
        MPI_Iprobe(0, kTagUnit, MPI_COMM_WORLD, &arrived, &status);
        if (!arrived) std::this_thread::sleep_for(kPoll);
      }
      int count = 0;
      MPI_Get_count(&status, MPI_INT64_T, &count);
      WorkUnit unit(static_cast<std::size_t>(count));
      MPI_Recv(unit.data(), count, MPI_INT64_T, 0, kTagUnit, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      if (unit.empty()) return;
      run_or_abort(work, unit);
    }
  }

  std::string command_;  // "insid bench": starts a rank's error message
  int rank_ = 0;
  int size_ = 1;
};

}  // namespace

bool built_with_mpi() { return true; }

std::unique_ptr<Cluster> join_mpi_launch(const std::string& command) {
  if (launched_world_size() <= 1) return nullptr;
  return std::make_unique<MpiCluster>(command);
}

}  // namespace insid::campaign
