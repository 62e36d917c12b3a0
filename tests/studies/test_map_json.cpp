// The map JSON round trip (map_to_json, map_from_json) that lets `stickslip map --server` print
// the same table as the local `map --db`.
#include "stickslip/studies/map.h"

#include <gtest/gtest.h>

#include <cmath>

namespace stickslip::studies {
namespace {

using nlohmann::json;

TEST(MapFromJson, RoundTripsTheStudiesMapSoTablesAreIdentical) {
  StudyMap m;
  m.study_id = "st-1";
  m.study_name = "n";
  m.state = "running";
  m.models = {"dahl", "lugre"};
  m.key_names = {"va_over_vd"};
  m.stages = 2;
  m.missing = 1;
  m.failed = 1;
  const double nan = std::nan("");
  for (int k = 0; k < 2; ++k) {
    MapRow row;
    row.key = {{"va_over_vd", 0.5 * k}};
    MapCell ok;
    ok.state = CellState::kOk;
    ok.design_index = 2 * k;
    ok.status = "ok";
    ok.amplitude = {2.0, k == 0 ? nan : 0.5};
    ok.mean_force = {10.0, 11.0};
    ok.ratio = k == 0 ? std::nullopt : std::optional<double>(0.25);
    ok.stage_rmse = {std::nullopt, 0.1};
    MapCell other;
    other.design_index = 2 * k + 1;
    if (k == 1) {
      other.state = CellState::kFailed;
      other.status = "diverged";
      other.error = "x = inf";
      other.amplitude = {nan, nan};
      other.mean_force = {nan, nan};
      other.stage_rmse = {std::nullopt, std::nullopt};
    }
    row.cells = {ok, other};
    m.rows.push_back(row);
  }
  const json j = map_to_json(m);
  const StudyMap back = map_from_json(j);
  EXPECT_EQ(map_to_json(back), j);
  for (const auto view : {MapView::kAmplitude, MapView::kMeanForce,
                          MapView::kRmse})
    EXPECT_EQ(map_to_table(back, view), map_to_table(m, view));
  EXPECT_EQ(map_to_csv(back), map_to_csv(m));
}

}  // namespace
}  // namespace stickslip::studies
