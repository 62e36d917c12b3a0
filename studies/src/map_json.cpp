// The JSON forms of a map (see map.h): map_to_json (rows), map_to_columns_json (columns) and
// map_from_json, the inverse of map_to_json, so that `stickslip map ID --server URL` prints the
// same table (map_to_table) as the local `stickslip map ID --db FILE`.
#include <algorithm>
#include <cmath>
#include <limits>

#include "stickslip/common/json_number.h"
#include "stickslip/studies/map.h"

namespace stickslip::studies {

using nlohmann::json;

namespace {
double number(const json& v) {
  return v.is_number() ? v.get<double>() : std::numeric_limits<double>::quiet_NaN();
}
std::optional<double> optional_number(const json& v) {
  if (!v.is_number()) return std::nullopt;
  return v.get<double>();
}
}  // namespace

json map_to_json(const StudyMap& map) {
  json out = {{"study_id", map.study_id}, {"study_name", map.study_name}, {"state", map.state},
              {"models", map.models},     {"key_names", map.key_names},   {"stages", map.stages},
              {"missing", map.missing},   {"failed", map.failed}};
  json rows = json::array();
  for (const MapRow& r : map.rows) {
    json key = json::object();
    for (const auto& [n, v] : r.key) key[n] = common::json_number(v);
    json cells = json::object();
    for (std::size_t m = 0; m < map.models.size(); ++m) {
      const MapCell& c = r.cells[m];
      if (c.design_index < 0) continue;
      json cell = {{"state", to_string(c.state)}, {"design_index", c.design_index}};
      if (c.state != CellState::kMissing) {
        cell["status"] = c.status;
        if (!c.error.empty()) cell["error"] = c.error;
        json amp = json::array(), mean = json::array(), srm = json::array();
        for (std::size_t s = 0; s < c.amplitude.size(); ++s) {
          amp.push_back(common::json_number(c.amplitude[s]));
          mean.push_back(common::json_number(c.mean_force[s]));
          srm.push_back(common::json_number(c.stage_rmse[s]));
        }
        cell["amplitude"] = amp;
        cell["mean_force"] = mean;
        cell["ratio"] = common::json_number(c.ratio);
        cell["rmse"] = common::json_number(c.rmse);
        cell["stage_rmse"] = srm;
      }
      cells[map.models[m]] = cell;
    }
    rows.push_back({{"key", key}, {"cells", cells}});
  }
  out["rows"] = rows;
  return out;
}

json map_to_columns_json(const StudyMap& map) {
  json out = {{"study_id", map.study_id}, {"study_name", map.study_name}, {"state", map.state},
              {"models", map.models},     {"key_names", map.key_names},   {"stages", map.stages},
              {"missing", map.missing},   {"failed", map.failed},         {"layout", "columns"}};
  const std::size_t n = map.rows.size();
  json keys = json::object();
  for (const auto& k : map.key_names) {
    json col = json::array();
    for (const MapRow& r : map.rows) {
      const auto it = std::find_if(r.key.begin(), r.key.end(),
                                   [&](const auto& kv) { return kv.first == k; });
      col.push_back(it == r.key.end() ? json(nullptr) : common::json_number(it->second));
    }
    keys[k] = std::move(col);
  }
  out["keys"] = std::move(keys);
  json cells = json::object();
  for (std::size_t m = 0; m < map.models.size(); ++m) {
    json state = json::array(), index = json::array(), ratio = json::array(),
         rmse = json::array(), error = json::array();
    std::vector<json> amp(map.stages, json::array()), mean(map.stages, json::array()),
        srm(map.stages, json::array());
    for (std::size_t i = 0; i < n; ++i) {
      const MapCell& c = map.rows[i].cells[m];
      const bool exists = c.design_index >= 0;
      const bool has = exists && c.state != CellState::kMissing;
      state.push_back(exists ? json(to_string(c.state)) : json(nullptr));
      index.push_back(exists ? json(c.design_index) : json(nullptr));
      for (std::size_t s = 0; s < map.stages; ++s) {
        const bool stage = has && s < c.amplitude.size();
        amp[s].push_back(stage ? common::json_number(c.amplitude[s]) : json(nullptr));
        mean[s].push_back(stage ? common::json_number(c.mean_force[s]) : json(nullptr));
        srm[s].push_back(stage && s < c.stage_rmse.size() ? common::json_number(c.stage_rmse[s])
                                                          : json(nullptr));
      }
      ratio.push_back(has ? common::json_number(c.ratio) : json(nullptr));
      rmse.push_back(has ? common::json_number(c.rmse) : json(nullptr));
      error.push_back(has && !c.error.empty() ? json(c.error) : json(nullptr));
    }
    cells[map.models[m]] = {{"state", std::move(state)},   {"design_index", std::move(index)},
                            {"amplitude", std::move(amp)}, {"mean_force", std::move(mean)},
                            {"ratio", std::move(ratio)},   {"rmse", std::move(rmse)},
                            {"stage_rmse", std::move(srm)}, {"error", std::move(error)}};
  }
  out["cells"] = std::move(cells);
  return out;
}

StudyMap map_from_json(const json& j) {
  StudyMap m;
  m.study_id = j.value("study_id", "");
  m.study_name = j.value("study_name", "");
  m.state = j.value("state", "");
  m.models = j.value("models", std::vector<std::string>{});
  m.key_names = j.value("key_names", std::vector<std::string>{});
  m.stages = j.value("stages", std::size_t{0});
  m.missing = j.value("missing", std::int64_t{0});
  m.failed = j.value("failed", std::int64_t{0});
  for (const auto& r : j.value("rows", json::array())) {
    MapRow row;
    for (const auto& name : m.key_names)
      row.key.emplace_back(name, number(r["key"].value(name, json(nullptr))));
    for (const auto& model : m.models) {
      MapCell c;
      c.amplitude.assign(m.stages, std::numeric_limits<double>::quiet_NaN());
      c.mean_force = c.amplitude;
      c.stage_rmse.assign(m.stages, std::nullopt);
      if (r["cells"].contains(model)) {
        const json& cj = r["cells"][model];
        const std::string state = cj.value("state", "missing");
        c.state = state == "ok"       ? CellState::kOk
                  : state == "failed" ? CellState::kFailed
                                      : CellState::kMissing;
        c.design_index = cj.value("design_index", std::int64_t{-1});
        c.status = cj.value("status", "");
        c.error = cj.value("error", "");
        for (std::size_t s = 0; s < m.stages; ++s) {
          if (cj.contains("amplitude") && s < cj["amplitude"].size())
            c.amplitude[s] = number(cj["amplitude"][s]);
          if (cj.contains("mean_force") && s < cj["mean_force"].size())
            c.mean_force[s] = number(cj["mean_force"][s]);
          if (cj.contains("stage_rmse") && s < cj["stage_rmse"].size())
            c.stage_rmse[s] = optional_number(cj["stage_rmse"][s]);
        }
        if (cj.contains("ratio")) c.ratio = optional_number(cj["ratio"]);
        if (cj.contains("rmse")) c.rmse = optional_number(cj["rmse"]);
      }
      row.cells.push_back(std::move(c));
    }
    m.rows.push_back(std::move(row));
  }
  return m;
}

}  // namespace stickslip::studies
