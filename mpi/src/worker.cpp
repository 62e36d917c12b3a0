// The worker ranks' loop (session.h, protocol.h).
#include <omp.h>

#include <optional>

#include "stickslip/mpi/protocol.h"
#include "stickslip/mpi/session.h"
#include "transport.h"

namespace stickslip::mpi {
namespace {

using namespace detail;

std::vector<studies::Job> decode_chunk(const std::vector<std::int64_t>& msg) {
  std::vector<studies::Job> jobs;
  std::size_t k = 1;
  const std::size_t n = msg.empty() ? 0 : static_cast<std::size_t>(msg[0]);
  for (std::size_t j = 0; j < n && k < msg.size(); ++j) {
    const auto size = static_cast<std::size_t>(msg[k++]);
    studies::Job job;
    for (std::size_t i = 0; i < size && k < msg.size(); ++i)
      job.push_back(static_cast<std::size_t>(msg[k++]));
    jobs.push_back(std::move(job));
  }
  return jobs;
}

void send_text(const std::string& text, int tag) {
  MPI_Send(text.data(), static_cast<int>(text.size()), MPI_BYTE, 0, tag, MPI_COMM_WORLD);
}

/// One study: ready, then chunks until kTagEnd. A study this rank cannot load is reported
/// (kTagFailed); rank 0 then ends the job.
void serve_study(const MPI_Status& begin, const ChunkCompute& compute) {
  const std::vector<std::uint8_t> bytes = recv_bytes(begin);
  std::optional<studies::wire::LoadedTask> task;
  studies::wire::Task t;
  try {
    t = studies::wire::decode_task(bytes.data(), bytes.size());
    task.emplace(studies::wire::load_task(t));
  } catch (const std::exception& e) {
    send_text(e.what(), kTagFailed);
    return;
  }
  const int threads = t.threads > 0 ? t.threads : omp_get_max_threads();
  const std::int64_t ready = threads;
  MPI_Send(&ready, 1, MPI_INT64_T, 0, kTagReady, MPI_COMM_WORLD);
  std::atomic<std::int64_t> batched{0};
  while (true) {
    const MPI_Status st = wait_probe(0);
    if (st.MPI_TAG == kTagEnd) {
      recv_int64(st);
      return;
    }
    const std::vector<studies::Job> jobs = decode_chunk(recv_int64(st));
    const studies::wire::Bytes runs =
        studies::wire::encode_runs(compute(*task, jobs, t.study_id, threads, &batched));
    MPI_Send(runs.data(), static_cast<int>(runs.size()), MPI_BYTE, 0, kTagRuns, MPI_COMM_WORLD);
  }
}

}  // namespace

std::vector<store::RunRecord> compute_chunk(const studies::wire::LoadedTask& task,
                                            const std::vector<studies::Job>& jobs,
                                            const std::string& study_id, int threads,
                                            std::atomic<std::int64_t>* batched) {
  std::vector<std::vector<store::RunRecord>> out(jobs.size());
  const measured::MeasuredDataset* m = task.measured ? &*task.measured : nullptr;
  const long n = static_cast<long>(jobs.size());
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (long k = 0; k < n; ++k) {
    const auto j = static_cast<std::size_t>(k);
    out[j] = studies::compute_job(task.spec, jobs[j], study_id, m, batched);  // never throws
  }
  std::vector<store::RunRecord> all;
  for (auto& recs : out)
    for (auto& r : recs) all.push_back(std::move(r));
  return all;
}

int Session::serve(const ChunkCompute& compute) {
  while (true) {
    const MPI_Status st = wait_probe(0);
    if (st.MPI_TAG == kTagShutdown) {
      recv_bytes(st);
      return finish(0);
    }
    if (st.MPI_TAG == kTagBegin) {
      serve_study(st, compute);
    } else {
      recv_bytes(st);  // a stray message of an ended study: nothing to do
    }
  }
}

}  // namespace stickslip::mpi
