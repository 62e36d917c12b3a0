#pragma once
// Internal to stickslip_store: Store's implementation, shared by the files that define its
// methods (studies.cpp, runs.cpp, diagnoses.cpp), and what more than one of them needs.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "connection.h"

namespace stickslip::store {

struct Store::Impl {
  detail::Connection conn;

  /// The first job matching where (a WHERE ... clause binding values to ?1, ?2, ...; jobs.cpp).
  std::optional<JobRecord> job_where(JobColumns cols, std::string_view where,
                                     std::initializer_list<std::string_view> values);

  /// The first study matching where (a WHERE ... clause with ?1 and optionally ?2; studies.cpp).
  /// Stage metrics of runs lo..hi (inclusive), merged into runs (sorted by design_index).
  void attach_stages(const std::string& study_id, std::vector<RunRecord>& runs);  // runs.cpp
};

namespace detail {

constexpr std::array<double TracePoint::*, 6> kTraceColumns{
    &TracePoint::t, &TracePoint::F_d, &TracePoint::F_f,
    &TracePoint::x, &TracePoint::v,   &TracePoint::s};

/// Columns after (study_id, design_index) in stage_metrics, in this order.
constexpr const char* kStageColumns =
    "stage, t_start, t_end, amplitude, amplitude_raw, mean_force, mean_friction, slip_events, "
    "mean_period, rmse";

inline std::int64_t to_limit(std::size_t n) {
  return static_cast<std::int64_t>(
      std::min<std::uint64_t>(n, std::numeric_limits<std::int64_t>::max()));
}

bool is_json_object(const std::string& text);
bool is_json(const std::string& text);

/// The state rule of every job (jobs.cpp): started_at set on the first 'running', finished_at
/// on a terminal state and cleared otherwise. kind (when not null) must match the job's.
void set_job_state(const Connection& conn, const std::string& id, const char* kind,
                   StudyState state, const std::optional<std::string>& error);

}  // namespace detail
}  // namespace stickslip::store
