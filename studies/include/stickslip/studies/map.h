#pragma once
// Stick-slip maps: per-stage amplitude, mean force and the stage-2/stage-1 reduction ratio of a
// stored study, one row per design point without its model (e.g. va_over_vd), one column per
// model. The expected cells come from the study's spec, so a run that is not stored yet is a
// "missing" cell and a failed run a "failed" cell; nothing is silently dropped.
//
// The same table also carries RMSE against measured data (whole run and per stage), which is how
// `stickslip rmse` prints the seed's Table 2 (RMSE per model per condition).

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "stickslip/store/store.h"

namespace stickslip::studies {

enum class CellState { kOk, kFailed, kMissing };
const char* to_string(CellState s) noexcept;

struct MapCell {
  CellState state = CellState::kMissing;
  std::int64_t design_index = -1;
  std::string status;  ///< run status ("ok", "diverged", "invalid"); empty when missing
  std::string error;   ///< reason of a failed run
  std::vector<double> amplitude;   ///< [N] per stage (NaN for a stage not reached)
  std::vector<double> mean_force;  ///< [N] per stage
  std::optional<double> ratio;     ///< amplitude of the last stage / first stage (none if the
                                   ///< first stage has no stick-slip)
  std::optional<double> rmse;                  ///< [N] whole run vs measured data
  std::vector<std::optional<double>> stage_rmse;  ///< [N] per stage
};

struct MapRow {
  std::vector<std::pair<std::string, double>> key;  ///< design variables except model (and v_a
                                                    ///< when va_over_vd is a variable)
  std::vector<MapCell> cells;                       ///< one per StudyMap::models entry
};

struct StudyMap {
  std::string study_id, study_name, state;
  std::vector<std::string> models;    ///< column order: order of first appearance in the design
  std::vector<std::string> key_names;
  std::size_t stages = 0;
  std::vector<MapRow> rows;           ///< sorted by key
  std::int64_t missing = 0, failed = 0;
};

/// Builds the map of a stored study. Throws StoreError (unknown study, unreadable store) and
/// std::invalid_argument when the stored spec no longer parses.
StudyMap build_map(store::Store& store, const std::string& study_id);

/// {"study_id", "models", "key_names", "stages", "missing", "failed", "rows": [{"key": {...},
/// "cells": {"<model>": {"state", "status", "error", "design_index", "amplitude": [..],
/// "mean_force": [..], "ratio", "rmse", "stage_rmse": [..]}}}]}; NaN is written as null.
nlohmann::json map_to_json(const StudyMap& map);
/// The inverse of map_to_json (a client reads GET /v1/studies/{id}/map with it): missing fields
/// take their defaults, null numbers read back as NaN (or none).
StudyMap map_from_json(const nlohmann::json& j);
/// The same map by columns, for large maps (one array per quantity instead of an object per
/// cell: about a third of the bytes and a fifth of the time of map_to_json at 50,000 cells):
/// {"study_id", "study_name", "state", "models", "key_names", "stages", "missing", "failed",
///  "layout": "columns", "keys": {"<name>": [value per row]}, "cells": {"<model>": {
///    "state": [per row: "ok" | "failed" | "missing", or null when the design has no such cell],
///    "design_index": [...], "amplitude": [[per row] per stage], "mean_force": [[...] per stage],
///    "ratio": [...], "rmse": [...], "stage_rmse": [[...] per stage], "error": [per row or null]}}}
/// NaN and absent values are null.
nlohmann::json map_to_columns_json(const StudyMap& map);
/// One line per (row, model): key columns, model, state, then per stage amplitude and
/// mean_force, ratio, rmse, per-stage rmse. Empty fields for missing values.
std::string map_to_csv(const StudyMap& map);
/// A readable table: one row per key, per model "amp1 amp2 ratio" (or "mean" / "rmse" views).
enum class MapView { kAmplitude, kMeanForce, kRmse };
std::string map_to_table(const StudyMap& map, MapView view = MapView::kAmplitude);

}  // namespace stickslip::studies
