// The RunWriter: the single writer of runs, in batched transactions (store.h).
#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "records.h"

namespace stickslip::store {

using detail::Connection;
using detail::fail;
using detail::is_json_object;
using detail::kStageColumns;
using detail::kTraceColumns;
using detail::SqliteError;
using detail::Statement;
using detail::Transaction;

namespace {

/// One trace column as n little-endian IEEE-754 binary64 values (numpy dtype '<f8').
std::vector<unsigned char> encode_column(const std::vector<TracePoint>& trace,
                                         double TracePoint::*column) {
  std::vector<unsigned char> out(trace.size() * 8);
  for (std::size_t i = 0; i < trace.size(); ++i) {
    const auto bits = std::bit_cast<std::uint64_t>(trace[i].*column);
    for (std::size_t k = 0; k < 8; ++k) out[8 * i + k] = static_cast<unsigned char>(bits >> (8 * k));
  }
  return out;
}

std::string run_label(const RunRecord& r) {
  return "run (" + r.study_id + ", " + std::to_string(r.design_index) + ")";
}

/// Checks a run before it is buffered; fills in stage numbers and finished_at.
void prepare_run(RunRecord& r, const std::filesystem::path& path) {
  const auto bad = [&](const std::string& why) { fail(path, "rejected " + run_label(r) + ": " + why); };
  if (r.study_id.empty()) bad("empty study_id");
  if (r.design_index < 0) bad("negative design_index");
  if (r.param_hash.empty()) bad("empty param_hash");
  if (!is_valid_run_status(r.status))
    bad("status '" + r.status + "' is not one of ok, diverged, invalid");
  if (!is_json_object(r.params_json)) bad("params_json is not a JSON object");
  std::vector<int> numbers;
  for (std::size_t i = 0; i < r.stages.size(); ++i) {
    if (r.stages[i].stage == 0) r.stages[i].stage = static_cast<int>(i + 1);
    if (r.stages[i].stage < 1) bad("stage numbers start at 1");
    numbers.push_back(r.stages[i].stage);
  }
  std::sort(numbers.begin(), numbers.end());
  if (std::adjacent_find(numbers.begin(), numbers.end()) != numbers.end())
    bad("repeated stage number");
  if (r.finished_at.empty()) r.finished_at = utc_now_iso8601();
}

}  // namespace

struct RunWriter::Impl {
  using Clock = std::chrono::steady_clock;
  enum class Outcome { kInserted, kDuplicate, kMismatch };

  Impl(Connection c, WriterOptions o)
      : conn(std::move(c)),
        options(o),
        insert_run(conn,
                   "INSERT INTO runs (study_id, design_index, param_hash, params_json, model, "
                   "va_over_vd, status, error, wall_time_s, t_end, steps, rmse, finished_at) "
                   "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13) "
                   "ON CONFLICT (study_id, design_index) DO NOTHING",
                   "inserting a run", true),
        stored_hash(conn,
                    "SELECT param_hash FROM runs WHERE study_id = ?1 AND design_index = ?2",
                    "reading the param_hash of a stored run", true),
        insert_stage(conn,
                     (std::string("INSERT INTO stage_metrics (study_id, design_index, ") +
                      kStageColumns + ") VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12)")
                         .c_str(),
                     "inserting stage metrics", true),
        insert_trace(conn,
                     "INSERT INTO traces (study_id, design_index, n_samples, t, F_d, F_f, x, v, s) "
                     "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)",
                     "inserting a trace", true) {}

  // Member order matters: statements are finalised before the connection closes.
  Connection conn;
  WriterOptions options;
  Statement insert_run, stored_hash, insert_stage, insert_trace;
  std::vector<RunRecord> buffer;
  Clock::time_point last_commit = Clock::now();
  // After a commit failed on a busy store: no automatic commit before retry_at.
  std::chrono::milliseconds busy_wait{0};
  Clock::time_point retry_at{};

  bool due() const {
    if (buffer.empty()) return false;
    const auto now = Clock::now();
    if (now < retry_at) return false;
    return busy_wait.count() > 0 || buffer.size() >= options.max_batch ||
           now - last_commit >= options.max_delay;
  }

  /// flush(), but a busy store only postpones the commit (the runs stay buffered).
  bool flush_unless_busy() {
    try {
      flush();
      return true;
    } catch (const StoreError& e) {
      if (e.fault() != StoreFault::kBusy) throw;
      return false;
    }
  }

  void write_stages(const RunRecord& r) {
    for (const auto& m : r.stages) {
      insert_stage.reset().bind_text(1, r.study_id).bind_int(2, r.design_index);
      insert_stage.bind_int(3, m.stage).bind_real(4, m.t_start).bind_real(5, m.t_end);
      insert_stage.bind_real(6, m.amplitude).bind_real(7, m.amplitude_raw);
      insert_stage.bind_real(8, m.mean_force).bind_real(9, m.mean_friction);
      insert_stage.bind_int(10, m.slip_events).bind_real(11, m.mean_period);
      insert_stage.bind_real(12, m.rmse).run();
    }
  }

  void write_trace(const RunRecord& r) {
    if (r.trace.empty()) return;
    insert_trace.reset().bind_text(1, r.study_id).bind_int(2, r.design_index);
    insert_trace.bind_int(3, static_cast<std::int64_t>(r.trace.size()));
    for (std::size_t c = 0; c < kTraceColumns.size(); ++c)
      insert_trace.bind_blob(static_cast<int>(c) + 4, encode_column(r.trace, kTraceColumns[c]));
    insert_trace.run();
  }

  Outcome existing_outcome(const RunRecord& r) {
    stored_hash.reset().bind_text(1, r.study_id).bind_int(2, r.design_index);
    const bool found = stored_hash.step();
    const std::string hash = found ? stored_hash.text(0) : std::string();
    stored_hash.reset();
    return found && hash == r.param_hash ? Outcome::kDuplicate : Outcome::kMismatch;
  }

  Outcome write_run(const RunRecord& r) {
    insert_run.reset().bind_text(1, r.study_id).bind_int(2, r.design_index);
    insert_run.bind_text(3, r.param_hash).bind_text(4, r.params_json).bind_opt_text(5, r.model);
    insert_run.bind_real(6, r.va_over_vd).bind_text(7, r.status);
    if (r.error.empty()) insert_run.bind_null(8);
    else insert_run.bind_text(8, r.error);
    insert_run.bind_real(9, r.wall_time_s).bind_real(10, r.t_end).bind_int(11, r.steps);
    insert_run.bind_real(12, r.rmse).bind_text(13, r.finished_at).run();
    if (conn.changes() == 0) return existing_outcome(r);
    write_stages(r);
    write_trace(r);
    return Outcome::kInserted;
  }

  /// Writes one run inside its own savepoint: a constraint violation drops just this run (its
  /// reason is appended to rejected); any other error propagates.
  void write_run_atomically(const RunRecord& r, FlushResult& result,
                            std::vector<std::string>& rejected) {
    conn.exec("SAVEPOINT run", "opening a savepoint for " + run_label(r));
    try {
      const Outcome o = write_run(r);
      if (o == Outcome::kInserted) ++result.inserted;
      if (o == Outcome::kDuplicate) ++result.duplicates;
      if (o == Outcome::kMismatch)
        rejected.push_back(run_label(r) + " is already stored with a different param_hash "
                           "(new " + r.param_hash + ")");
    } catch (const SqliteError& e) {
      if (!e.is_constraint()) throw;
      conn.exec("ROLLBACK TO run", "rolling back " + run_label(r));
      rejected.push_back(run_label(r) + ": " + e.what());
    }
    conn.exec("RELEASE run", "releasing the savepoint of " + run_label(r));
  }

  FlushResult flush() {
    if (buffer.empty()) return {};
    const std::string doing = "a batch of " + std::to_string(buffer.size()) + " runs";
    FlushResult result;
    std::vector<std::string> rejected;
    try {
      Transaction tx(conn, Transaction::Kind::kWrite, doing);
      for (const auto& r : buffer) write_run_atomically(r, result, rejected);
      tx.commit(doing);
    } catch (const StoreError& e) {
      if (e.fault() == StoreFault::kBusy) {  // another connection holds the write lock
        busy_wait = std::clamp(busy_wait * 2, std::chrono::milliseconds(50),
                               std::chrono::milliseconds(2000));
        retry_at = Clock::now() + busy_wait;
      }
      throw;
    }
    busy_wait = std::chrono::milliseconds(0);
    buffer.clear();
    last_commit = Clock::now();
    if (!rejected.empty()) throw_rejected(rejected, result);
    return result;
  }

  [[noreturn]] void throw_rejected(const std::vector<std::string>& rejected,
                                   const FlushResult& result) const {
    std::string msg = "committed " + std::to_string(result.inserted) + " runs (" +
                      std::to_string(result.duplicates) + " duplicates) but left out " +
                      std::to_string(rejected.size()) + ":";
    for (const auto& r : rejected) msg += "\n  " + r;
    fail(conn.path(), msg);
  }
};

RunWriter::RunWriter(std::unique_ptr<Impl> impl) noexcept : impl_(std::move(impl)) {}
RunWriter::RunWriter(RunWriter&&) noexcept = default;

RunWriter& RunWriter::operator=(RunWriter&& other) noexcept {
  if (this != &other) {
    RunWriter old(std::move(*this));  // flushes on destruction
    impl_ = std::move(other.impl_);
  }
  return *this;
}

RunWriter::~RunWriter() {
  if (!impl_ || impl_->buffer.empty()) return;
  try {
    impl_->flush();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "stickslip RunWriter: final flush failed: %s\n", e.what());
  } catch (...) {
    std::fprintf(stderr, "stickslip RunWriter: final flush failed\n");
  }
}

RunWriter RunWriter::open(const std::filesystem::path& path, WriterOptions options) {
  if (options.max_batch == 0) options.max_batch = 1;
  Connection conn = detail::open_connection(path, Store::Mode::kReadWriteCreate, options.busy_timeout);
  return RunWriter(std::make_unique<Impl>(std::move(conn), options));
}

void RunWriter::add(RunRecord run) {
  prepare_run(run, impl_->conn.path());
  impl_->buffer.push_back(std::move(run));
  flush_if_due();
}

bool RunWriter::flush_if_due() {
  if (!impl_->due()) return false;
  return impl_->flush_unless_busy();
}

FlushResult RunWriter::flush() { return impl_->flush(); }

std::size_t RunWriter::buffered() const noexcept { return impl_->buffer.size(); }

const std::filesystem::path& RunWriter::path() const noexcept { return impl_->conn.path(); }

}  // namespace stickslip::store
