#pragma once
// Dynamic chunk scheduling for a dedicated master (Dakota's "dedicated master" self-scheduling):
// the study's jobs (compute.h), in order, are handed out in chunks of consecutive jobs to
// whichever worker asks next. Chunk sizes follow guided self-scheduling bounded by time:
//   size = max(1, min(ceil(remaining / (guided_factor * workers)),
//                     max(threads, runs that fill target_s on the worker's threads)))
// so chunks are long enough that messages stay rare, and shrink towards the end so that a chunk
// of slow runs handed out last cannot leave the other workers idle for long. The first chunk a
// worker gets holds one job per thread (nothing is known of the runs' cost yet); every
// returned chunk updates the estimate of the thread-seconds a run takes.
//
// A chunk's deadline is max(deadline_floor_s, deadline_factor x its expected time): a chunk
// not returned by then means its worker hung or was lost.
//
// Pure bookkeeping (no MPI, no clock): the master passes the times in, so it is tested alone.

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace stickslip::studies {

struct ChunkOptions {
  double target_s = 2.0;            ///< wall time a chunk should take on its worker [s]
  double guided_factor = 2.0;       ///< remaining / (factor x workers) bounds a chunk [-]
  std::size_t max_runs = 4096;      ///< most runs in one chunk (bounds a message's size)
  double deadline_floor_s = 120.0;  ///< a chunk's deadline is never shorter [s]
  double deadline_factor = 10.0;    ///< ... else this many times its expected time [-]

  /// True if every field holds; else appends one message per broken field (name and value).
  bool IsValid(std::vector<std::string>* errors = nullptr) const;
};

/// A slice of the job list: jobs [first_job, first_job + jobs), holding `runs` runs.
struct Chunk {
  std::size_t id = 0;  ///< 0, 1, ... in the order handed out
  std::size_t first_job = 0, jobs = 0, runs = 0;
};

class ChunkScheduler {
 public:
  /// job_runs[k]: runs of job k. workers >= 1. Throws std::invalid_argument for bad options.
  ChunkScheduler(std::vector<std::size_t> job_runs, int workers, ChunkOptions options = {});

  /// The next chunk for a worker with `threads` OpenMP threads; nullopt once every job has
  /// been handed out.
  std::optional<Chunk> next(int threads);
  /// A chunk came back after `seconds` [s] on a worker with `threads` threads.
  void returned(const Chunk& chunk, double seconds, int threads);
  /// How long the chunk may take on a worker with `threads` threads before it is late [s].
  double deadline(const Chunk& chunk, int threads) const;

  std::size_t remaining_jobs() const noexcept { return job_runs_.size() - next_job_; }
  /// Thread-seconds per run so far; nullopt before the first chunk came back.
  std::optional<double> seconds_per_run() const;

 private:
  std::vector<std::size_t> job_runs_;
  int workers_;
  ChunkOptions opt_;
  std::size_t next_job_ = 0, next_id_ = 0;
  double thread_seconds_ = 0;  // sum over returned chunks of seconds x threads
  std::size_t runs_back_ = 0;  // runs in returned chunks
  std::size_t runs_total_ = 0;
};

}  // namespace stickslip::studies
