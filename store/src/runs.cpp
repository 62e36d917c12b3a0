// Run records of the store, read side (store.h); they are written by the RunWriter
// (run_writer.cpp).
#include <bit>
#include <cstdint>
#include <string>
#include <vector>

#include "records.h"

namespace stickslip::store {

using detail::fail;
using detail::kStageColumns;
using detail::kTraceColumns;
using detail::Statement;
using detail::to_limit;
using detail::Transaction;

namespace {

void decode_column(const std::vector<unsigned char>& bytes, std::vector<TracePoint>& trace,
                   double TracePoint::*column) {
  for (std::size_t i = 0; i < trace.size(); ++i) {
    std::uint64_t bits = 0;
    for (std::size_t k = 0; k < 8; ++k) bits |= std::uint64_t{bytes[8 * i + k]} << (8 * k);
    trace[i].*column = std::bit_cast<double>(bits);
  }
}

constexpr const char* kRunColumns =
    "study_id, design_index, param_hash, params_json, model, va_over_vd, status, error, "
    "wall_time_s, t_end, steps, rmse, finished_at";

RunRecord read_run(const Statement& st) {
  RunRecord r;
  r.study_id = st.text(0);
  r.design_index = st.int64(1);
  r.param_hash = st.text(2);
  r.params_json = st.text(3);
  r.model = st.opt_text(4);
  r.va_over_vd = st.opt_real(5);
  r.status = st.text(6);
  r.error = st.opt_text(7).value_or("");
  r.wall_time_s = st.real(8);
  r.t_end = st.real(9);
  r.steps = st.int64(10);
  r.rmse = st.opt_real(11);
  r.finished_at = st.text(12);
  return r;
}

/// Reads kStageColumns starting at column c0.
StageMetricsRecord read_stage(const Statement& st, int c0) {
  StageMetricsRecord m;
  m.stage = static_cast<int>(st.int64(c0));
  m.t_start = st.real(c0 + 1);
  m.t_end = st.real(c0 + 2);
  m.amplitude = st.real(c0 + 3);
  m.amplitude_raw = st.real(c0 + 4);
  m.mean_force = st.real(c0 + 5);
  m.mean_friction = st.real(c0 + 6);
  m.slip_events = st.int64(c0 + 7);
  m.mean_period = st.real(c0 + 8);
  m.rmse = st.opt_real(c0 + 9);
  return m;
}

}  // namespace

/// Stage metrics of runs lo..hi (inclusive), merged into runs (sorted by design_index).
void Store::Impl::attach_stages(const std::string& study_id, std::vector<RunRecord>& runs) {
  Statement st(conn,
               (std::string("SELECT design_index, ") + kStageColumns +
                " FROM stage_metrics WHERE study_id = ?1 AND design_index BETWEEN ?2 AND ?3 "
                "ORDER BY design_index, stage")
                   .c_str(),
               "reading stage metrics of study " + study_id);
  st.bind_text(1, study_id).bind_int(2, runs.front().design_index);
  st.bind_int(3, runs.back().design_index);
  auto it = runs.begin();
  while (st.step()) {
    const std::int64_t index = st.int64(0);
    while (it != runs.end() && it->design_index < index) ++it;
    if (it == runs.end()) break;
    if (it->design_index == index) it->stages.push_back(read_stage(st, 1));
  }
}

std::vector<std::int64_t> Store::completed_design_indices(const std::string& study_id) {
  Statement st(impl_->conn,
               "SELECT design_index FROM runs WHERE study_id = ?1 ORDER BY design_index",
               "reading completed design indices of study " + study_id);
  st.bind_text(1, study_id);
  std::vector<std::int64_t> out;
  while (st.step()) out.push_back(st.int64(0));
  return out;
}

std::vector<RunRecord> Store::get_runs(const std::string& study_id, std::int64_t after_index,
                                       std::size_t limit) {
  const std::string doing = "reading runs of study " + study_id;
  Transaction snapshot(impl_->conn, Transaction::Kind::kRead, doing);
  Statement st(impl_->conn,
               (std::string("SELECT ") + kRunColumns +
                " FROM runs WHERE study_id = ?1 AND design_index > ?2 "
                "ORDER BY design_index LIMIT ?3")
                   .c_str(),
               doing);
  st.bind_text(1, study_id).bind_int(2, after_index).bind_int(3, to_limit(limit));
  std::vector<RunRecord> runs;
  while (st.step()) runs.push_back(read_run(st));
  if (!runs.empty()) impl_->attach_stages(study_id, runs);
  snapshot.commit(doing);
  return runs;
}

RunCounts Store::count_runs(const std::string& study_id) {
  Statement st(impl_->conn,
               "SELECT total, done, ok, failed FROM v_study_progress WHERE study_id = ?1",
               "counting runs of study " + study_id);
  st.bind_text(1, study_id);
  if (!st.step()) fail(path(), "counting runs of study " + study_id + ": no such study");
  return {st.int64(0), st.int64(1), st.int64(2), st.int64(3)};
}

std::optional<std::vector<TracePoint>> Store::get_trace(const std::string& study_id,
                                                        std::int64_t design_index) {
  Statement st(impl_->conn,
               "SELECT n_samples, t, F_d, F_f, x, v, s FROM traces "
               "WHERE study_id = ?1 AND design_index = ?2",
               "reading a trace of study " + study_id);
  st.bind_text(1, study_id).bind_int(2, design_index);
  if (!st.step()) return std::nullopt;
  std::vector<TracePoint> trace(static_cast<std::size_t>(st.int64(0)));
  for (std::size_t c = 0; c < kTraceColumns.size(); ++c) {
    const auto bytes = st.blob(static_cast<int>(c) + 1);
    if (bytes.size() != 8 * trace.size())
      fail(path(), "corrupt trace of study " + study_id + " design_index " +
                       std::to_string(design_index) + ": column length mismatch");
    decode_column(bytes, trace, kTraceColumns[c]);
  }
  return trace;
}

}  // namespace stickslip::store
