// Tasks and runs as MessagePack (wire.h).
#include "stickslip/studies/wire.h"

#include <cstring>
#include <filesystem>

#include "stickslip/common/json_schema.h"

namespace stickslip::studies::wire {
namespace {

using nlohmann::json;

json optional_number(const std::optional<double>& v) { return v ? json(*v) : json(nullptr); }
std::optional<double> number_or_null(const json& j) {
  if (j.is_null()) return std::nullopt;
  return j.get<double>();
}

json stage_json(const store::StageMetricsRecord& m) {
  return json::array({m.stage, m.t_start, m.t_end, m.amplitude, m.amplitude_raw, m.mean_force,
                      m.mean_friction, m.slip_events, m.mean_period, optional_number(m.rmse)});
}

store::StageMetricsRecord stage_from(const json& j) {
  if (!j.is_array() || j.size() != 10) throw WireError("a stage is not an array of 10 values");
  store::StageMetricsRecord m;
  m.stage = j[0].get<int>();
  m.t_start = j[1].get<double>();
  m.t_end = j[2].get<double>();
  m.amplitude = j[3].get<double>();
  m.amplitude_raw = j[4].get<double>();
  m.mean_force = j[5].get<double>();
  m.mean_friction = j[6].get<double>();
  m.slip_events = j[7].get<std::int64_t>();
  m.mean_period = j[8].get<double>();
  m.rmse = number_or_null(j[9]);
  return m;
}

// The trace as raw doubles (t, F_d, F_f, x, v, s per sample) in this machine's byte order: the
// ranks of one job share an architecture.
json trace_json(const std::vector<store::TracePoint>& trace) {
  static_assert(sizeof(store::TracePoint) == 6 * sizeof(double));
  std::vector<std::uint8_t> bin(trace.size() * sizeof(store::TracePoint));
  if (!trace.empty()) std::memcpy(bin.data(), trace.data(), bin.size());
  return json::binary(std::move(bin));
}

std::vector<store::TracePoint> trace_from(const json& j) {
  if (!j.is_binary()) throw WireError("a trace is not binary");
  const json::binary_t& bin = j.get_binary();
  if (bin.size() % sizeof(store::TracePoint) != 0)
    throw WireError("a trace of " + std::to_string(bin.size()) + " bytes is not whole samples");
  std::vector<store::TracePoint> out(bin.size() / sizeof(store::TracePoint));
  if (!out.empty()) std::memcpy(out.data(), bin.data(), bin.size());
  return out;
}

json run_json(const store::RunRecord& r) {
  json stages = json::array();
  for (const auto& m : r.stages) stages.push_back(stage_json(m));
  return json::array({r.design_index, r.param_hash, r.params_json,
                      r.model ? json(*r.model) : json(nullptr), optional_number(r.va_over_vd),
                      r.status, r.error, r.wall_time_s, r.t_end, r.steps,
                      optional_number(r.rmse), std::move(stages), trace_json(r.trace)});
}

store::RunRecord run_from(const json& j, const std::string& study_id) {
  if (!j.is_array() || j.size() != 13) throw WireError("a run is not an array of 13 values");
  store::RunRecord r;
  r.study_id = study_id;
  r.design_index = j[0].get<std::int64_t>();
  r.param_hash = j[1].get<std::string>();
  r.params_json = j[2].get<std::string>();
  if (!j[3].is_null()) r.model = j[3].get<std::string>();
  r.va_over_vd = number_or_null(j[4]);
  r.status = j[5].get<std::string>();
  r.error = j[6].get<std::string>();
  r.wall_time_s = j[7].get<double>();
  r.t_end = j[8].get<double>();
  r.steps = j[9].get<std::int64_t>();
  r.rmse = number_or_null(j[10]);
  for (const json& s : j[11]) r.stages.push_back(stage_from(s));
  r.trace = trace_from(j[12]);
  return r;
}

// Pending indices as [first, last + 1) ranges: a study's missing runs are mostly contiguous.
json ranges_json(const std::vector<std::size_t>& indices) {
  json out = json::array();
  for (std::size_t k = 0; k < indices.size();) {
    std::size_t e = k + 1;
    while (e < indices.size() && indices[e] == indices[e - 1] + 1) ++e;
    out.push_back(json::array({indices[k], indices[e - 1] + 1}));
    k = e;
  }
  return out;
}

std::vector<std::size_t> ranges_from(const json& j) {
  std::vector<std::size_t> out;
  for (const json& r : j) {
    const auto a = r.at(0).get<std::size_t>(), b = r.at(1).get<std::size_t>();
    if (b < a) throw WireError("a pending range ends before it starts");
    for (std::size_t i = a; i < b; ++i) out.push_back(i);
  }
  return out;
}

}  // namespace

json decode_json(const std::uint8_t* data, std::size_t size) {
  try {
    return json::from_msgpack(data, data + size);
  } catch (const json::exception& e) {
    throw WireError(std::string("malformed message: ") + e.what());
  }
}

Bytes encode_task(const Task& t) {
  const json j{{"study_id", t.study_id},
               {"spec", t.spec_json},
               {"limits",
                {{"max_runs", t.limits.max_runs},
                 {"max_duration", t.limits.max_duration},
                 {"min_dt", t.limits.min_dt},
                 {"max_dt", t.limits.max_dt}}},
               {"spec_dir", t.spec_dir},
               {"pending", ranges_json(t.pending)},
               {"threads", t.threads},
               {"chunk_deadline_s", t.chunk_deadline_s}};
  return json::to_msgpack(j);
}

Task decode_task(const std::uint8_t* data, std::size_t size) {
  const json j = decode_json(data, size);
  try {
    Task t;
    t.study_id = j.at("study_id").get<std::string>();
    t.spec_json = j.at("spec").get<std::string>();
    const json& l = j.at("limits");
    t.limits.max_runs = l.at("max_runs").get<std::size_t>();
    t.limits.max_duration = l.at("max_duration").get<double>();
    t.limits.min_dt = l.at("min_dt").get<double>();
    t.limits.max_dt = l.at("max_dt").get<double>();
    t.spec_dir = j.at("spec_dir").get<std::string>();
    t.pending = ranges_from(j.at("pending"));
    t.threads = j.at("threads").get<int>();
    t.chunk_deadline_s = j.at("chunk_deadline_s").get<double>();
    return t;
  } catch (const json::exception& e) {
    throw WireError(std::string("malformed task: ") + e.what());
  }
}

LoadedTask load_task(const Task& t) {
  ParseResult parsed = parse_study(t.spec_json, t.limits);
  if (!parsed.ok())
    throw WireError("the study's spec does not parse here: " + common::to_string(parsed.errors));
  if (parsed.spec->canonical_json() != t.spec_json)
    throw WireError("the study's spec has another canonical form here (another stickslip "
                    "version on this node?)");
  LoadedTask out{std::move(*parsed.spec), std::nullopt};
  if (const auto& m = out.spec.measured()) {
    std::filesystem::path path = *m;
    if (path.is_relative()) path = std::filesystem::path(t.spec_dir) / path;
    try {
      out.measured = measured::load_measured(path);
    } catch (const measured::MeasuredError& e) {
      throw WireError(std::string("measured data: ") + e.what());
    }
  }
  return out;
}

Bytes encode_runs(const std::vector<store::RunRecord>& runs) {
  json all = json::array();
  for (const auto& r : runs) all.push_back(run_json(r));
  return json::to_msgpack(all);
}

std::vector<store::RunRecord> decode_runs(const std::uint8_t* data, std::size_t size,
                                          const std::string& study_id) {
  const json all = decode_json(data, size);
  if (!all.is_array()) throw WireError("runs: not an array");
  std::vector<store::RunRecord> out;
  out.reserve(all.size());
  try {
    for (const json& j : all) out.push_back(run_from(j, study_id));
  } catch (const json::exception& e) {
    throw WireError(std::string("malformed run: ") + e.what());
  }
  return out;
}

}  // namespace stickslip::studies::wire
