// Dynamic chunk scheduling (chunks.h).
#include "stickslip/studies/chunks.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>
#include <stdexcept>

#include "stickslip/common/text.h"

namespace stickslip::studies {
namespace {
std::string number(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}
}  // namespace

bool ChunkOptions::IsValid(std::vector<std::string>* errors) const {
  bool ok = true;
  auto check = [&](bool holds, const std::string& what, double value) {
    if (holds) return;
    ok = false;
    if (errors != nullptr) errors->push_back(what + ", got " + number(value));
  };
  check(target_s > 0 && std::isfinite(target_s), "target_s: must be > 0 s", target_s);
  check(guided_factor >= 1 && std::isfinite(guided_factor), "guided_factor: must be >= 1",
        guided_factor);
  check(max_runs >= 1, "max_runs: must be >= 1", static_cast<double>(max_runs));
  check(deadline_floor_s > 0 && std::isfinite(deadline_floor_s),
        "deadline_floor_s: must be > 0 s", deadline_floor_s);
  check(deadline_factor >= 1 && std::isfinite(deadline_factor),
        "deadline_factor: must be >= 1", deadline_factor);
  return ok;
}

ChunkScheduler::ChunkScheduler(std::vector<std::size_t> job_runs, int workers,
                               ChunkOptions options)
    : job_runs_(std::move(job_runs)), workers_(workers), opt_(options) {
  std::vector<std::string> errors;
  if (workers < 1) errors.push_back("workers: must be >= 1, got " + std::to_string(workers));
  opt_.IsValid(&errors);
  if (!errors.empty()) throw std::invalid_argument("ChunkScheduler: " + common::join(errors, "; "));
  runs_total_ = std::accumulate(job_runs_.begin(), job_runs_.end(), std::size_t{0});
}

std::optional<double> ChunkScheduler::seconds_per_run() const {
  if (runs_back_ == 0) return std::nullopt;
  return thread_seconds_ / static_cast<double>(runs_back_);
}

std::optional<Chunk> ChunkScheduler::next(int threads) {
  if (next_job_ >= job_runs_.size()) return std::nullopt;
  threads = std::max(threads, 1);
  const std::size_t remaining = remaining_jobs();
  const auto guided = static_cast<std::size_t>(
      std::ceil(static_cast<double>(remaining) / (opt_.guided_factor * workers_)));
  std::size_t want = static_cast<std::size_t>(threads);  // first chunk: one job per thread
  if (const auto spr = seconds_per_run()) {
    const double runs_per_job =
        static_cast<double>(runs_total_) / static_cast<double>(job_runs_.size());
    const double by_time = opt_.target_s * threads / std::max(*spr * runs_per_job, 1e-12);
    want = std::max(want, static_cast<std::size_t>(std::min(by_time, 1e15)));
  }
  std::size_t jobs = std::max<std::size_t>(1, std::min({guided, want, remaining}));
  Chunk c;
  c.id = next_id_++;
  c.first_job = next_job_;
  // At least one job, else as many as fit in max_runs.
  c.runs = job_runs_[next_job_];
  c.jobs = 1;
  while (c.jobs < jobs && c.runs + job_runs_[next_job_ + c.jobs] <= opt_.max_runs)
    c.runs += job_runs_[next_job_ + c.jobs++];
  next_job_ += c.jobs;
  return c;
}

void ChunkScheduler::returned(const Chunk& chunk, double seconds, int threads) {
  thread_seconds_ += std::max(seconds, 0.0) * std::max(threads, 1);
  runs_back_ += chunk.runs;
}

double ChunkScheduler::deadline(const Chunk& chunk, int threads) const {
  const auto spr = seconds_per_run();
  if (!spr) return opt_.deadline_floor_s;
  const double expected = *spr * static_cast<double>(chunk.runs) / std::max(threads, 1);
  return std::max(opt_.deadline_floor_s, opt_.deadline_factor * expected);
}

}  // namespace stickslip::studies
