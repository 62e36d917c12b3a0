// Stick-slip maps of stored studies (see map.h).
#include "stickslip/studies/map.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <stdexcept>

#include "stickslip/studies/spec.h"

namespace stickslip::studies {
namespace {

std::string fmt(double v, const char* f = "%.4g") {
  if (!std::isfinite(v)) return "";
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// Design variables of a point that identify its row: everything but the model, and the derived
// v_a when va_over_vd is a variable.
std::vector<std::pair<std::string, double>> row_key(const DesignPoint& p) {
  std::vector<std::pair<std::string, double>> key;
  const bool has_ratio = p.value("va_over_vd").has_value();
  for (const auto& [name, v] : p.values)
    if (!(has_ratio && name == "v_a")) key.emplace_back(name, v);
  return key;
}

}  // namespace

const char* to_string(CellState s) noexcept {
  switch (s) {
    case CellState::kOk: return "ok";
    case CellState::kFailed: return "failed";
    case CellState::kMissing: return "missing";
  }
  return "?";
}

namespace {

using CellPlace = std::pair<std::size_t, std::size_t>;  // (row, column)

/// The map's models, key names, rows and expected cells from the design; returns where each
/// design index lands. Throws when two design points fall in one cell.
std::vector<CellPlace> expected_cells(const StudySpec& spec, const std::string& study_id,
                                      StudyMap& map) {
  std::map<std::vector<double>, std::size_t> row_of;   // key values -> row
  std::vector<CellPlace> where(spec.run_count());
  for (std::size_t i = 0; i < spec.run_count(); ++i) {
    const DesignPoint p = spec.point(i);
    const std::string model = p.model.empty() ? std::string("-") : p.model;
    auto mit = std::find(map.models.begin(), map.models.end(), model);
    if (mit == map.models.end()) {
      map.models.push_back(model);
      for (MapRow& r : map.rows) r.cells.emplace_back();
      mit = map.models.end() - 1;
    }
    const auto key = row_key(p);
    for (const auto& [name, v] : key)
      if (std::find(map.key_names.begin(), map.key_names.end(), name) == map.key_names.end())
        map.key_names.push_back(name);
    std::vector<double> kv(map.key_names.size(), std::nan(""));
    for (const auto& [name, v] : key)
      kv[std::find(map.key_names.begin(), map.key_names.end(), name) - map.key_names.begin()] = v;
    auto [it, inserted] = row_of.try_emplace(kv, map.rows.size());
    if (inserted) {
      MapRow row;
      row.key = key;
      row.cells.resize(map.models.size());
      map.rows.push_back(std::move(row));
    }
    const std::size_t col = static_cast<std::size_t>(mit - map.models.begin());
    MapCell& cell = map.rows[it->second].cells[col];
    if (cell.design_index >= 0)
      throw std::invalid_argument("study " + study_id + ": design points " +
                                  std::to_string(cell.design_index) + " and " + std::to_string(i) +
                                  " fall in the same map cell; the map needs one run per model "
                                  "and design point");
    cell.design_index = static_cast<std::int64_t>(i);
    where[i] = {it->second, col};
  }
  for (MapRow& r : map.rows) r.cells.resize(map.models.size());
  return where;
}

/// A stored run's metrics in its cell.
void fill_cell(MapCell& c, const store::RunRecord& run, std::size_t stages) {
  c.status = run.status;
  c.error = run.error;
  c.state = run.status == "ok" ? CellState::kOk : CellState::kFailed;
  c.amplitude.assign(stages, std::nan(""));
  c.mean_force.assign(stages, std::nan(""));
  c.stage_rmse.assign(stages, std::nullopt);
  for (const store::StageMetricsRecord& s : run.stages) {
    if (s.stage < 1 || static_cast<std::size_t>(s.stage) > stages) continue;
    c.amplitude[s.stage - 1] = s.amplitude;
    c.mean_force[s.stage - 1] = s.mean_force;
    c.stage_rmse[s.stage - 1] = s.rmse;
  }
  c.rmse = run.rmse;
  if (stages >= 2 && std::isfinite(c.amplitude.front()) && c.amplitude.front() > 0 &&
      std::isfinite(c.amplitude.back()))
    c.ratio = c.amplitude.back() / c.amplitude.front();
}

}  // namespace

StudyMap build_map(store::Store& store, const std::string& study_id) {
  const auto study = store.get_study(study_id);
  if (!study) throw store::StoreError("unknown study '" + study_id + "' in " + store.path().string());
  ParseResult parsed = parse_study(study->spec_json, Limits{.max_runs = static_cast<std::size_t>(
                                                                std::max<std::int64_t>(study->total_runs, 1))});
  if (!parsed.ok())
    throw std::invalid_argument("study " + study_id + ": its stored spec does not parse: " +
                                parsed.errors.front().pointer + ": " +
                                parsed.errors.front().message);
  const StudySpec& spec = *parsed.spec;

  StudyMap map;
  map.study_id = study->id;
  map.study_name = study->name;
  map.state = to_string(study->state);
  map.stages = spec.is_analytic() ? 1 : spec.base_config().stages.size();
  const std::vector<CellPlace> where = expected_cells(spec, study_id, map);

  // Stored runs.
  std::int64_t after = -1;
  while (true) {
    const auto runs = store.get_runs(study_id, after, 2000);
    if (runs.empty()) break;
    for (const store::RunRecord& run : runs) {
      after = run.design_index;
      if (run.design_index < 0 || static_cast<std::size_t>(run.design_index) >= where.size()) continue;
      const auto [row, col] = where[run.design_index];
      fill_cell(map.rows[row].cells[col], run, map.stages);
    }
  }
  for (const MapRow& r : map.rows)
    for (const MapCell& c : r.cells) {
      if (c.design_index < 0) continue;  // no design point for this model on this row
      map.missing += c.state == CellState::kMissing;
      map.failed += c.state == CellState::kFailed;
    }
  std::stable_sort(map.rows.begin(), map.rows.end(), [](const MapRow& a, const MapRow& b) {
    return a.key < b.key;
  });
  return map;
}

std::string map_to_csv(const StudyMap& map) {
  std::ostringstream o;
  for (const auto& k : map.key_names) o << k << ',';
  o << "model,state,design_index";
  for (std::size_t s = 1; s <= map.stages; ++s) o << ",amplitude_" << s << ",mean_force_" << s;
  o << ",ratio,rmse";
  for (std::size_t s = 1; s <= map.stages; ++s) o << ",rmse_" << s;
  o << ",error\n";
  for (const MapRow& r : map.rows)
    for (std::size_t m = 0; m < map.models.size(); ++m) {
      const MapCell& c = r.cells[m];
      if (c.design_index < 0) continue;
      for (const auto& k : map.key_names) {
        const auto it = std::find_if(r.key.begin(), r.key.end(),
                                     [&](const auto& kv) { return kv.first == k; });
        o << (it == r.key.end() ? "" : fmt(it->second, "%.10g")) << ',';
      }
      o << map.models[m] << ',' << to_string(c.state) << ',' << c.design_index;
      for (std::size_t s = 0; s < map.stages; ++s) {
        const bool have = s < c.amplitude.size();
        o << ',' << (have ? fmt(c.amplitude[s], "%.10g") : "") << ','
          << (have ? fmt(c.mean_force[s], "%.10g") : "");
      }
      o << ',' << (c.ratio ? fmt(*c.ratio, "%.10g") : "") << ','
        << (c.rmse ? fmt(*c.rmse, "%.10g") : "");
      for (std::size_t s = 0; s < map.stages; ++s)
        o << ',' << (s < c.stage_rmse.size() && c.stage_rmse[s] ? fmt(*c.stage_rmse[s], "%.10g") : "");
      std::string err = c.error;
      std::replace(err.begin(), err.end(), '"', '\'');
      o << ",\"" << err << "\"\n";
    }
  return o.str();
}

std::string map_to_table(const StudyMap& map, MapView view) {
  std::ostringstream o;
  const char* what = view == MapView::kAmplitude ? "stick-slip amplitude [N] per stage, ratio = last/first"
                     : view == MapView::kMeanForce ? "mean drive force [N] per stage"
                                                   : "RMSE against measured F_d [N]: whole run, then per stage";
  o << "study " << map.study_id << " (" << map.study_name << "), " << map.state << ": " << what
    << "\n";
  const int cw = 26;
  std::string head;
  for (const auto& k : map.key_names) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%-11s", k.c_str());
    head += buf;
  }
  o << head;
  for (const auto& m : map.models) {
    char buf[64];
    std::snprintf(buf, sizeof buf, " | %-*s", cw, m.c_str());
    o << buf;
  }
  o << "\n";
  for (const MapRow& r : map.rows) {
    for (const auto& k : map.key_names) {
      const auto it = std::find_if(r.key.begin(), r.key.end(), [&](const auto& kv) { return kv.first == k; });
      char buf[32];
      std::snprintf(buf, sizeof buf, "%-11s", it == r.key.end() ? "" : fmt(it->second, "%.5g").c_str());
      o << buf;
    }
    for (const MapCell& c : r.cells) {
      std::string text;
      if (c.design_index < 0) text = "";
      else if (c.state == CellState::kMissing) text = "(missing)";
      else if (c.state == CellState::kFailed) text = "(" + c.status + ")";
      else {
        for (std::size_t s = 0; s < map.stages; ++s) {
          const double v = view == MapView::kMeanForce ? c.mean_force[s]
                           : view == MapView::kAmplitude ? c.amplitude[s]
                           : (c.stage_rmse[s] ? *c.stage_rmse[s] : std::nan(""));
          if (s > 0) text += ' ';
          text += std::isfinite(v) ? fmt(v, "%.3f") : std::string("-");
        }
        if (view == MapView::kAmplitude && map.stages >= 2)
          text += " r=" + (c.ratio ? fmt(*c.ratio, "%.2f") : std::string("-"));
        if (view == MapView::kRmse) text = (c.rmse ? fmt(*c.rmse, "%.3f") : std::string("-")) + ": " + text;
      }
      char buf[128];
      std::snprintf(buf, sizeof buf, " | %-*s", cw, text.c_str());
      o << buf;
    }
    o << "\n";
  }
  o << map.rows.size() << " rows x " << map.models.size() << " models; missing " << map.missing
    << ", failed " << map.failed << "\n";
  return o.str();
}

}  // namespace stickslip::studies
