// Rank 0's backend: the dedicated master that hands chunks of jobs to the worker ranks
// (session.h, protocol.h).
#include <unistd.h>

#include <chrono>
#include <optional>
#include <sstream>

#include "master.h"
#include "stickslip/mpi/protocol.h"
#include "stickslip/studies/compute.h"
#include "stickslip/studies/wire.h"
#include "transport.h"

namespace stickslip::mpi::detail {
namespace {

using Clock = std::chrono::steady_clock;
using studies::Chunk;
using studies::ExecutorError;

std::string seconds_text(double s) {
  std::ostringstream out;
  out.precision(3);
  out << s;
  return out.str();
}

/// One study on the master: from kTagBegin to the last kTagEnd.
class Round {
 public:
  Round(const studies::ComputeRequest& req, const studies::RecordSink& sink,
        const studies::StopFn& stop, int workers, studies::ChunkOptions opt)
      : req_(req), sink_(sink), stop_(stop), workers_(workers), state_(workers + 1) {
    if (req.chunk_deadline_s > 0) opt.deadline_floor_s = req.chunk_deadline_s;
    jobs_ = studies::make_jobs(*req.spec, req.pending, studies::batchable(*req.spec, req.measured));
    std::vector<std::size_t> sizes;
    for (const auto& j : jobs_) sizes.push_back(j.size());
    scheduler_.emplace(std::move(sizes), workers, opt);
  }

  void run() {
    begin();
    Backoff backoff;
    auto last_check = Clock::now();
    while (ended_ < workers_) {
      MPI_Status st;
      if (probe(MPI_ANY_SOURCE, &st)) {
        on_message(st);
        backoff.reset();
      } else {
        sends_.progress();
        backoff.sleep();
      }
      if (Clock::now() - last_check > std::chrono::milliseconds(10)) {
        check_deadlines();
        last_check = Clock::now();
      }
    }
    for (int i = 0; i < 1000 && sends_.progress() > 0; ++i) backoff.sleep();
  }

 private:
  struct Worker {
    int threads = 0;  // 0 until it said ready
    bool ended = false;
    std::optional<Chunk> chunk;
    Clock::time_point sent;
    double deadline_s = 0;
  };

  void begin() {
    studies::wire::Task t;
    t.study_id = req_.study_id;
    t.spec_json = req_.spec->canonical_json();
    t.limits = req_.spec->limits();
    t.spec_dir = req_.spec_dir.string();
    t.threads = req_.threads;
    t.chunk_deadline_s = req_.chunk_deadline_s;
    const studies::wire::Bytes task = studies::wire::encode_task(t);
    for (int w = 1; w <= workers_; ++w) sends_.bytes(task, w, kTagBegin);
    begun_ = Clock::now();
  }

  void on_message(const MPI_Status& st) {
    const int w = st.MPI_SOURCE;
    switch (st.MPI_TAG) {
      case kTagReady: {
        const auto ints = recv_int64(st);
        state_[w].threads = ints.empty() ? 1 : static_cast<int>(std::max<std::int64_t>(ints[0], 1));
        dispatch(w);
        return;
      }
      case kTagRuns: return on_runs(w, recv_bytes(st));
      case kTagFailed: {
        const auto text = recv_bytes(st);
        throw ExecutorError("rank " + std::to_string(w) + " cannot compute the study: " +
                            std::string(text.begin(), text.end()));
      }
      default:
        recv_bytes(st);
        throw ExecutorError("rank " + std::to_string(w) + " sent an unexpected message (tag " +
                            std::to_string(st.MPI_TAG) + ")");
    }
  }

  void on_runs(int w, const std::vector<std::uint8_t>& bytes) {
    Worker& s = state_[w];
    if (!s.chunk)
      throw ExecutorError("rank " + std::to_string(w) + " returned runs it was not given");
    std::vector<store::RunRecord> recs =
        studies::wire::decode_runs(bytes.data(), bytes.size(), req_.study_id);
    if (recs.size() != s.chunk->runs)
      throw ExecutorError("rank " + std::to_string(w) + " returned " +
                          std::to_string(recs.size()) + " runs for a chunk of " +
                          std::to_string(s.chunk->runs));
    const double took = std::chrono::duration<double>(Clock::now() - s.sent).count();
    scheduler_->returned(*s.chunk, took, s.threads);
    if (req_.batched != nullptr)
      for (std::size_t k = 0; k < s.chunk->jobs; ++k)
        if (const auto n = jobs_[s.chunk->first_job + k].size(); n > 1)
          *req_.batched += static_cast<std::int64_t>(n);
    s.chunk.reset();
    sink_(std::move(recs));
    dispatch(w);
  }

  /// The next chunk for worker w, or kTagEnd when nothing is left or a stop was asked.
  void dispatch(int w) {
    Worker& s = state_[w];
    std::optional<Chunk> c;
    if (!stop_()) c = scheduler_->next(s.threads);
    if (!c) {
      sends_.int64({}, w, kTagEnd);
      s.ended = true;
      ++ended_;
      return;
    }
    std::vector<std::int64_t> msg{static_cast<std::int64_t>(c->jobs)};
    for (std::size_t k = 0; k < c->jobs; ++k) {
      const studies::Job& job = jobs_[c->first_job + k];
      msg.push_back(static_cast<std::int64_t>(job.size()));
      for (std::size_t i : job) msg.push_back(static_cast<std::int64_t>(i));
    }
    sends_.int64(std::move(msg), w, kTagChunk);
    s.chunk = c;
    s.sent = Clock::now();
    s.deadline_s = scheduler_->deadline(*c, s.threads);
  }

  void check_deadlines() const {
    const auto now = Clock::now();
    const double floor = scheduler_->deadline(Chunk{}, 1);  // nothing returned: the floor
    for (int w = 1; w <= workers_; ++w) {
      const Worker& s = state_[w];
      if (s.threads == 0 && !s.ended &&
          std::chrono::duration<double>(now - begun_).count() > floor)
        throw ExecutorError("rank " + std::to_string(w) + " did not answer the start of the "
                            "study within " + seconds_text(floor) +
                            " s: the rank hung or was lost");
      if (!s.chunk || std::chrono::duration<double>(now - s.sent).count() <= s.deadline_s)
        continue;
      const studies::Job& first = jobs_[s.chunk->first_job];
      throw ExecutorError("rank " + std::to_string(w) + " did not return chunk " +
                          std::to_string(s.chunk->id) + " (" + std::to_string(s.chunk->runs) +
                          " runs from design index " + std::to_string(first.front()) +
                          ") within its deadline of " + seconds_text(s.deadline_s) +
                          " s: the rank hung or was lost");
    }
  }

  const studies::ComputeRequest& req_;
  const studies::RecordSink& sink_;
  const studies::StopFn& stop_;
  const int workers_;
  std::vector<Worker> state_;  // by rank; [0] unused
  std::vector<studies::Job> jobs_;
  std::optional<studies::ChunkScheduler> scheduler_;
  Sends sends_;
  Clock::time_point begun_;
  int ended_ = 0;
};

}  // namespace

void MasterExecutor::compute(const studies::ComputeRequest& req,
                             const studies::RecordSink& sink, const studies::StopFn& stop) {
  std::lock_guard lock(mu_);  // one study at a time: the workers serve one study at a time
  if (broken_->load())
    throw ExecutorError("the MPI job lost a rank in an earlier study; start it again");
  try {
    Round(req, sink, stop, workers_, chunks_).run();
  } catch (...) {
    broken_->store(true);  // the workers' state is unknown: the session must abort
    throw;
  }
}

std::string MasterExecutor::running_note() const {
  char host[256] = "?";
  ::gethostname(host, sizeof host - 1);
  return "computing in an MPI job of " + std::to_string(workers_ + 1) + " ranks (rank 0: pid " +
         std::to_string(::getpid()) + " on host " + host + ", since " + store::utc_now_iso8601() +
         "). If that process has ended and the study is still running, the job was lost: a "
         "rank died and the launcher ended the whole job. The runs stored are kept; run the "
         "study again to compute the missing ones";
}

std::string MasterExecutor::describe() const {
  return "MPI (" + std::to_string(workers_) + " worker rank" + (workers_ == 1 ? "" : "s") + ")";
}

}  // namespace stickslip::mpi::detail
