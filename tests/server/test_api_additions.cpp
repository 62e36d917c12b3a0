// The /v1 additions the dashboard uses (and the command line can): the name filter of the
// studies list, the map by columns, and a diagnosis' stored traces (listed, decimated,
// windowed, CSV) with its cause_view. Handlers called without sockets.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "stickslip/server/api.h"
#include "stickslip/store/store.h"
#include "test_support.h"

namespace stickslip::server {
namespace {

using nlohmann::json;
using testing::body_json;
using testing::get;
using testing::post_json;
using testing::TempDir;
using testing::tiny_study;

/// The server's CSV number format (shortest of %.15g..%.17g that reads back exactly).
std::string testing_number(double v) {
  char buf[40];
  for (int p = 15; p <= 17; ++p) {
    std::snprintf(buf, sizeof buf, "%.*g", p, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}

class ApiAdditions : public ::testing::Test {
 protected:
  ApiOptions options() {
    ApiOptions o;
    o.db = dir_ / "d.db";
    return o;
  }
  TempDir dir_;
};

TEST_F(ApiAdditions, StudiesListFiltersByNameAcrossPages) {
  Api api(options());
  for (const std::string name : {"map-a", "other", "Map-B", "map-c", "mapless"})
    ASSERT_EQ(api.handle(post_json("/v1/studies", tiny_study(name))).status, 202);
  std::vector<std::string> seen;
  std::string target = "/v1/studies?page_size=1&name=MAP-";
  for (int pages = 0; pages < 10; ++pages) {
    const json page = body_json(api.handle(get(target)));
    for (const auto& s : page["studies"]) seen.push_back(s["name"]);
    if (page["next_page_token"].is_null()) break;
    target = "/v1/studies?page_size=1&name=MAP-&page_token=" + page["next_page_token"].get<std::string>();
  }
  // Each match once, one per page (ids made in the same millisecond sort by their random part,
  // so the order among these is not the creation order).
  std::sort(seen.begin(), seen.end());
  EXPECT_EQ(seen, (std::vector<std::string>{"Map-B", "map-a", "map-c"}));
  // No wildcard meaning: '%' and '_' are plain characters.
  EXPECT_TRUE(body_json(api.handle(get("/v1/studies?name=%25")))["studies"].empty());
  EXPECT_EQ(body_json(api.handle(get("/v1/studies?name=")))["studies"].size(), 5u);
  const Response bad = api.handle(get("/v1/studies?name=" + std::string(201, 'x')));
  EXPECT_EQ(bad.status, 400);
  EXPECT_EQ(body_json(bad)["errors"][0]["parameter"], "name");
}

store::RunRecord run(const std::string& study, std::int64_t index, const std::string& model,
                       double ratio, const std::string& status = "ok") {
  store::RunRecord r;
  r.study_id = study;
  r.design_index = index;
  r.params_json = json({{"model", model}, {"va_over_vd", ratio}}).dump();
  r.param_hash = store::param_hash(r.params_json);
  r.model = model;
  r.va_over_vd = ratio;
  r.status = status;
  r.steps = 10;
  if (status == "ok") {
    for (int s = 1; s <= 2; ++s) {
      store::StageMetricsRecord m;
      m.stage = s;
      m.amplitude = s == 1 ? 2.0 : 0.5 + ratio;
      m.mean_force = 10.0 + s;
      r.stages.push_back(m);
    }
  } else {
    r.error = "diverged";
  }
  return r;
}

TEST_F(ApiAdditions, MapByColumnsHoldsTheSameCellsAsTheRows) {
  Api api(options());
  const std::string id = body_json(api.handle(post_json("/v1/studies", tiny_study())))["id"];
  {
    auto writer = store::RunWriter::open(dir_ / "d.db");
    writer.add(run(id, 0, "dahl", 0));
    writer.add(run(id, 1, "dahl", 2, "diverged"));
    writer.add(run(id, 3, "lugre", 2));
    writer.flush();
  }
  const json rows = body_json(api.handle(get("/v1/studies/" + id + "/map")));
  const Response r = api.handle(get("/v1/studies/" + id + "/map?layout=columns"));
  ASSERT_EQ(r.status, 200) << r.body;
  const json c = body_json(r);
  EXPECT_EQ(c["layout"], "columns");
  for (const char* k : {"models", "key_names", "stages", "missing", "failed", "study_id"})
    EXPECT_EQ(c[k], rows[k]) << k;
  ASSERT_EQ(c["keys"]["va_over_vd"].size(), rows["rows"].size());
  for (std::size_t i = 0; i < rows["rows"].size(); ++i) {
    const json& row = rows["rows"][i];
    EXPECT_EQ(c["keys"]["va_over_vd"][i], row["key"]["va_over_vd"]);
    for (const auto& [model, cell] : row["cells"].items()) {
      const json& col = c["cells"][model];
      EXPECT_EQ(col["state"][i], cell["state"]) << i << model;
      EXPECT_EQ(col["design_index"][i], cell["design_index"]);
      if (cell["state"] == "missing") {
        EXPECT_TRUE(col["amplitude"][1][i].is_null());
        continue;
      }
      for (std::size_t s = 0; s < 2; ++s) {
        EXPECT_EQ(col["amplitude"][s][i], cell["amplitude"][s]) << i << model << s;
        EXPECT_EQ(col["mean_force"][s][i], cell["mean_force"][s]);
      }
      EXPECT_EQ(col["ratio"][i], cell["ratio"]);
      EXPECT_EQ(col["error"][i], cell.contains("error") ? cell["error"] : json(nullptr));
    }
  }
  EXPECT_EQ(c["cells"]["lugre"]["ratio"][1], 1.25);  // (0.5 + 2) / 2
  EXPECT_EQ(api.handle(get("/v1/studies/" + id + "/map?layout=diagonal")).status, 400);
}

/// A finished diagnosis with two runs' traces (the second without an extended model).
std::string stored_diagnosis(const std::filesystem::path& db, std::vector<store::DiagnosisTrace>* out) {
  auto store = store::Store::open(db);
  store::NewDiagnosis nd;
  nd.name = "bench";
  nd.request_json = R"({"manifest": {}, "files": {}})";
  nd.request_hash = store::param_hash(nd.request_json);
  const std::string id = store.create_diagnosis(nd).diagnosis.id;
  store::DiagnosisTrace a;
  a.run = "va0";
  for (int i = 0; i < 1000; ++i) {
    const double t = 0.01 * i;
    a.t.push_back(t);
    a.measured.push_back(std::sin(t) + (i == 537 ? 5.0 : 0.0) - (i == 612 ? 4.0 : 0.0));  // spikes
    a.base.push_back(std::sin(t) * 0.9);
    a.extended.push_back(std::sin(t) * 0.99);
  }
  store::DiagnosisTrace b = a;
  b.run = "va4";
  b.extended.clear();
  store.set_diagnosis_state(id, store::StudyState::kRunning);
  EXPECT_TRUE(store.finish_diagnosis(id, store::StudyState::kSucceeded,
                                     R"({"cause": "dwell_time", "dataset": "bench"})", std::nullopt,
                                     {a, b}));
  *out = {a, b};
  return id;
}

TEST_F(ApiAdditions, DiagnosisTracesAreListedDecimatedWindowedAndServedAsCsv) {
  Api api(options());
  std::vector<store::DiagnosisTrace> traces;
  const std::string id = stored_diagnosis(dir_ / "d.db", &traces);
  const std::string base = "/v1/diagnoses/" + id;

  const json d = body_json(api.handle(get(base)));
  EXPECT_EQ(d["cause_view"], "stick_time");  // diagnosis::evidence_view("dwell_time")
  EXPECT_EQ(d["links"]["traces"], base + "/traces");

  const json list = body_json(api.handle(get(base + "/traces")));
  ASSERT_EQ(list["runs"].size(), 2u);
  EXPECT_EQ(list["runs"][0]["run"], "va0");
  EXPECT_EQ(list["runs"][0]["samples"], 1000);
  EXPECT_EQ(list["runs"][0]["t_first"], 0.0);
  EXPECT_DOUBLE_EQ(list["runs"][0]["t_last"].get<double>(), 9.99);
  EXPECT_EQ(list["runs"][0]["extended"], true);
  EXPECT_EQ(list["runs"][1]["extended"], false);

  // Whole: every sample, exactly.
  const json whole = body_json(api.handle(get(base + "/traces/0?max_points=1000")));
  EXPECT_EQ(whole["decimated"], false);
  EXPECT_EQ(whole["t"].get<std::vector<double>>(), traces[0].t);
  EXPECT_EQ(whole["measured"].get<std::vector<double>>(), traces[0].measured);
  EXPECT_EQ(whole["base"].get<std::vector<double>>(), traces[0].base);
  EXPECT_EQ(whole["extended"].get<std::vector<double>>(), traces[0].extended);
  EXPECT_TRUE(body_json(api.handle(get(base + "/traces/1")))["extended"].is_null());

  // Decimated to 100 points: min and max per bucket, so both spikes survive, in time order.
  const json dec = body_json(api.handle(get(base + "/traces/0?max_points=100")));
  EXPECT_EQ(dec["decimated"], true);
  EXPECT_EQ(dec["samples"], 1000);
  EXPECT_LE(dec["returned"].get<int>(), 100);
  const auto m = dec["measured"].get<std::vector<double>>();
  EXPECT_DOUBLE_EQ(*std::max_element(m.begin(), m.end()), traces[0].measured[537]);
  EXPECT_DOUBLE_EQ(*std::min_element(m.begin(), m.end()), traces[0].measured[612]);
  const auto t = dec["t"].get<std::vector<double>>();
  EXPECT_TRUE(std::is_sorted(t.begin(), t.end()));

  // A window [t_min, t_max] at full resolution.
  const json win = body_json(api.handle(get(base + "/traces/0?t_min=2&t_max=3")));
  EXPECT_EQ(win["samples"], 101);
  EXPECT_EQ(win["decimated"], false);
  EXPECT_DOUBLE_EQ(win["t"].front().get<double>(), 2.0);
  EXPECT_DOUBLE_EQ(win["t"].back().get<double>(), 3.0);

  // CSV: every sample of the window, with the residuals.
  const Response csv = api.handle(get(base + "/traces/1?format=csv&t_max=0.015"));
  ASSERT_EQ(csv.status, 200);
  EXPECT_EQ(csv.header("Content-Type"), "text/csv; charset=utf-8");
  EXPECT_EQ(csv.body,
            "t,measured,base,extended,residual_base,residual_extended\n"
            "0,0,0,,0,\n0.01," + testing_number(traces[1].measured[1]) + "," +
                testing_number(traces[1].base[1]) + ",," +
                testing_number(traces[1].measured[1] - traces[1].base[1]) + ",\n");

  for (const std::string bad : {"/traces/0?max_points=1", "/traces/0?max_points=x",
                                "/traces/0?t_min=3&t_max=2", "/traces/0?t_min=nan"})
    EXPECT_EQ(api.handle(get(base + bad)).status, 400) << bad;
  for (const std::string missing : {"/traces/2", "/traces/-1", "/traces/x"})
    EXPECT_EQ(api.handle(get(base + missing)).status, 404) << missing;
  EXPECT_EQ(api.handle(get("/v1/diagnoses/dg-none/traces")).status, 404);
}

}  // namespace
}  // namespace stickslip::server
