// The nightly report end to end on a small configuration (short friction runs, analytic
// Sobol/Morris studies): configuration errors, reuse of studies, "changed since last night"
// (nothing flagged for identical results; exactly the moved map cells after a parameter change;
// indices whose intervals separate), and a well-formed self-contained HTML page whose plots exist.
#include "stickslip/reports/report.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <sstream>

#include "stickslip/studies/map.h"

#include "support/temp_dir.h"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace stickslip;
using namespace stickslip::reports;

// A fresh temp directory per test, removed at scope exit.
struct TempDir : stickslip::testing::TempDir {
  TempDir() : stickslip::testing::TempDir("stickslip-report") {}
};

// A small nightly: a 2 x 3 map (2.5 s still + 1 s vibrating: the first slip comes at 0.95 s),
// 2 x 2 traced runs, and analytic Sobol / Morris studies (cheap, known answers).
json small_config(double map_F_S = 11.1) {
  return json::parse(R"({
    "name": "small", "description": "test report",
    "threads": 2,
    "map_tolerance": {"abs": 0.05, "rel": 0.02},
    "indices": {"resamples": 200},
    "studies": [
      {"id": "map", "kind": "map", "spec": {"name": "small-map", "base": {"F_S": 11.1},
        "stages": [{"duration": 2.5}, {"duration": 1}],
        "design": {"type": "grid", "axes": [{"name": "model", "values": ["karnopp", "lugre"]},
                                            {"name": "va_over_vd", "values": [0, 0.5, 3]}]}}},
      {"id": "figs", "kind": "traces", "spec": {"name": "small-figs",
        "stages": [{"duration": 1.5}, {"duration": 0.5}],
        "design": {"type": "grid", "axes": [{"name": "model", "values": ["karnopp", "lugre"]},
                                            {"name": "v_a", "values": [0, 0.004]}]},
        "outputs": {"traces": {"rate": 500}}}},
      {"id": "sobol", "kind": "indices", "outputs": ["y"],
       "spec": {"name": "small-sobol", "base": {"model": "ishigami"},
                "design": {"type": "sobol", "n": 256}}},
      {"id": "morris", "kind": "indices",
       "spec": {"name": "small-morris", "base": {"model": "ishigami"},
                "design": {"type": "morris", "trajectories": 20}}}
    ]})")
      .patch(json::parse(R"([{"op": "replace", "path": "/studies/0/spec/base/F_S", "value": )" +
                         std::to_string(map_F_S) + "}]"));
}

ReportConfig parse_ok(const json& doc, const fs::path& dir = ".") {
  ReportConfigResult r = parse_report_config(doc.dump(), dir);
  if (!r.ok()) throw std::runtime_error("config does not parse: " + to_string(r.errors));
  return std::move(*r.config);
}

ReportResult build(const ReportConfig& cfg, const TempDir& dir, const std::string& date) {
  ReportOptions opt;
  opt.db = dir / "night.db";
  opt.out_dir = dir / "out";
  opt.date = date;
  ReportResult r = build_report(cfg, opt);
  EXPECT_TRUE(r.ok) << r.error;
  return r;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(ReportConfig, ShippedNightlyConfigParses) {
  const fs::path cfg = fs::path(STICKSLIP_SOURCE_DIR) / "reports" / "nightly.json";
  const ReportConfigResult r = parse_report_config(slurp(cfg), cfg.parent_path());
  ASSERT_TRUE(r.ok()) << to_string(r.errors);
  ASSERT_EQ(r.config->entries.size(), 4u);
  const ReportEntry& sobol = r.config->entries[2];
  EXPECT_EQ(sobol.spec->design().type, studies::DesignType::kSobol);
  EXPECT_EQ(sobol.spec->variables(),
            (std::vector<std::string>{"F_S", "F_C", "k_t", "v_s", "h_t", "k_d", "m", "v_d", "v_a",
                                      "f"}));
  // Every point of the shipped designs is a valid configuration: a single invalid run would make
  // every index of the nightly invalid. F_S and F_C both span +-20 % of Table 1 (11.1 N, 8.3 N),
  // so some points have F_S < F_C; the specs raise F_S to F_C there (about 4 % of a uniform box).
  for (std::size_t e : {2u, 3u}) {
    const studies::StudySpec& spec = *r.config->entries[e].spec;
    ASSERT_EQ(spec.F_S_below_F_C(), studies::FsBelowFc::kRaiseToFc) << "entry " << e;
    const auto& ranges = spec.design().ranges;
    for (const auto& rg : ranges) {
      const double seed = rg.name == "F_S" ? 11.1 : rg.name == "F_C" ? 8.3 : 0.0;
      if (seed > 0) {
        EXPECT_NEAR(rg.min, 0.8 * seed, 1e-9) << rg.name;
        EXPECT_NEAR(rg.max, 1.2 * seed, 1e-9) << rg.name;
      }
    }
    std::size_t raised = 0;
    // Every point the design can grow to (the Sobol entry runs until its intervals are narrow).
    for (std::size_t i = 0; i < spec.max_run_count(); ++i) {
      const studies::DesignPoint p = spec.point(i);
      stickslip::engine::SimConfig c;
      ASSERT_NO_THROW(c = spec.config_for(p)) << "entry " << e << " point " << i;
      EXPECT_GE(c.friction["F_S"], c.friction["F_C"]) << "entry " << e << " point " << i;
      if (spec.raises_F_S(p)) ++raised;
    }
    const double share = static_cast<double>(raised) / static_cast<double>(spec.max_run_count());
    if (e == 2u) {
      EXPECT_GT(share, 0.01) << "the Sobol design should reach the F_S < F_C corner";
    }
    EXPECT_LT(share, 0.10) << "entry " << e;
  }
}

TEST(ReportConfig, EveryErrorNamesItsField) {
  json doc = small_config();
  doc["studies"][1]["id"] = "map";                            // duplicate id
  doc["studies"][2]["outputs"] = {"stage2.amplitude"};       // not an output of ishigami
  doc["studies"][3]["kind"] = "map";                          // morris design as a map
  doc["studies"].push_back({{"id", "file"}, {"kind", "map"}, {"spec", "no/such/file.json"}});
  const ReportConfigResult r = parse_report_config(doc.dump(), "/nonexistent-dir");
  ASSERT_FALSE(r.ok());
  std::set<std::string> pointers;
  for (const auto& e : r.errors) pointers.insert(e.pointer);
  EXPECT_TRUE(pointers.count("/studies/1/id")) << to_string(r.errors);
  EXPECT_TRUE(pointers.count("/studies/2/outputs/0")) << to_string(r.errors);
  EXPECT_TRUE(pointers.count("/studies/3/spec")) << to_string(r.errors);
  EXPECT_TRUE(pointers.count("/studies/4/spec")) << to_string(r.errors);

  json bad = small_config();
  bad["colour"] = "red";
  bad["studies"][0]["spec"]["base"]["m"] = -1;
  const ReportConfigResult r2 = parse_report_config(bad.dump(), ".");
  ASSERT_FALSE(r2.ok());
  // The schema is checked first: the unknown field is reported (the spec is not looked at yet).
  EXPECT_EQ(r2.errors.at(0).pointer, "/colour") << to_string(r2.errors);
  bad.erase("colour");
  const ReportConfigResult r3 = parse_report_config(bad.dump(), ".");
  ASSERT_FALSE(r3.ok());
  EXPECT_EQ(r3.errors.at(0).pointer, "/studies/0/spec/base/m") << to_string(r3.errors);
}

TEST(Report, FindPreviousSummaryTakesNewestOlderDate) {
  TempDir dir;
  for (const char* d : {"2026-01-01", "2026-01-03", "2026-01-05", "notes"}) {
    fs::create_directories(dir / d);
    std::ofstream(dir / d / "summary.json") << "{}";
  }
  fs::create_directories(dir / "2026-01-04");  // no summary: an interrupted night
  EXPECT_EQ(find_previous_summary(dir.path(), "2026-01-05"), dir / "2026-01-03" / "summary.json");
  EXPECT_EQ(find_previous_summary(dir.path(), "2026-01-02"), dir / "2026-01-01" / "summary.json");
  EXPECT_FALSE(find_previous_summary(dir.path(), "2026-01-01").has_value());
  EXPECT_EQ(list_report_dates(dir.path()),
            (std::vector<std::string>{"2026-01-05", "2026-01-03", "2026-01-01"}));
  EXPECT_TRUE(list_report_dates(dir / "missing").empty());
  EXPECT_FALSE(is_valid_date("2026-02-30"));
  EXPECT_TRUE(is_valid_date("2024-02-29"));
}

TEST(Report, IdenticalResultsFlagNothingAndReuseStudies) {
  TempDir dir;
  const ReportConfig cfg = parse_ok(small_config());
  const ReportResult a = build(cfg, dir, "2026-03-01");
  ASSERT_TRUE(a.ok);
  EXPECT_FALSE(a.previous_date.has_value());
  EXPECT_TRUE(fs::exists(dir / "out/2026-03-01/index.html"));
  EXPECT_TRUE(fs::exists(dir / "out/2026-03-01/summary.json"));
  std::int64_t computed_first = 0;
  for (const auto& r : a.runs) computed_first += r.run.computed;
  EXPECT_EQ(computed_first, 6 + 4 + 256 * 5 + 20 * 4);

  const ReportResult b = build(cfg, dir, "2026-03-02");
  ASSERT_TRUE(b.ok);
  ASSERT_TRUE(b.previous_date.has_value());
  EXPECT_EQ(*b.previous_date, "2026-03-01");
  for (const auto& r : b.runs) EXPECT_EQ(r.run.computed, 0) << r.entry_id << " was recomputed";
  EXPECT_EQ(b.flagged, 0u) << b.summary_json["changes"].dump(1);
  EXPECT_TRUE(b.summary_json["changes"]["notes"].empty()) << b.summary_json["changes"].dump(1);
  // The summary on disk is the one returned, with the comparison in it.
  const json on_disk = json::parse(slurp(b.summary));
  EXPECT_EQ(on_disk["changes"]["previous_date"], "2026-03-01");
  EXPECT_EQ(on_disk["changes"]["flagged"], 0);
  EXPECT_EQ(on_disk["entries"]["sobol"]["indices"]["valid"], true);
  EXPECT_EQ(on_disk["failures"]["total"], 0);
}

TEST(Report, ParameterChangeFlagsExactlyTheMovedMapCells) {
  TempDir dir;
  const ReportResult a = build(parse_ok(small_config(11.1)), dir, "2026-03-01");
  ASSERT_TRUE(a.ok);
  // Tonight someone raised the static friction of the map study: stick-slip grows where it exists.
  const ReportResult b = build(parse_ok(small_config(12.5)), dir, "2026-03-02");
  ASSERT_TRUE(b.ok);
  const json& ch = b.summary_json["changes"];
  EXPECT_EQ(ch["indices"].size(), 0u) << "the sensitivity studies did not change";
  ASSERT_EQ(ch["notes"].size(), 1u) << ch.dump(1);
  EXPECT_NE(ch["notes"][0].get<std::string>().find("entry map: the study spec changed"),
            std::string::npos);

  // Independently: the cells whose amplitude moved beyond the tolerance, from the two maps.
  store::Store store = store::Store::open(dir / "night.db", store::Store::Mode::kReadOnly);
  const studies::StudyMap before = studies::build_map(store, a.summary_json["entries"]["map"]["study_id"]);
  const studies::StudyMap after = studies::build_map(store, b.summary_json["entries"]["map"]["study_id"]);
  ASSERT_NE(before.study_id, after.study_id);
  std::set<std::string> expected, flagged;
  for (std::size_t r = 0; r < after.rows.size(); ++r)
    for (std::size_t m = 0; m < after.models.size(); ++m)
      for (std::size_t s = 0; s < 2; ++s) {
        const double x = before.rows[r].cells[m].amplitude[s];
        const double y = after.rows[r].cells[m].amplitude[s];
        if (std::abs(y - x) > 0.05 + 0.02 * std::abs(x))
          expected.insert(after.models[m] + " " + std::to_string(after.rows[r].key[0].second) +
                          " " + std::to_string(s + 1));
      }
  for (const json& f : ch["map_cells"]) {
    ASSERT_TRUE(f.contains("stage")) << f.dump();
    flagged.insert(f["model"].get<std::string>() + " " +
                   std::to_string(f["key"]["va_over_vd"].get<double>()) + " " +
                   std::to_string(f["stage"].get<int>()));
  }
  EXPECT_EQ(flagged, expected);
  // The physics: with a still base both models stick and slip, and a larger F_S - F_C gives a
  // larger saw-tooth, so stage 1 at va_over_vd = 0 must be among the flagged cells.
  EXPECT_TRUE(flagged.count("karnopp " + std::to_string(0.0) + " 1"));
  EXPECT_TRUE(flagged.count("lugre " + std::to_string(0.0) + " 1"));
  EXPECT_EQ(b.flagged, flagged.size());
  // And the page lists them.
  const std::string html = slurp(b.html);
  EXPECT_NE(html.find("Map cells"), std::string::npos);
}

// An index is flagged when its interval and the previous one no longer overlap (and only then).
TEST(Report, IndexFlaggedWhenIntervalsSeparate) {
  const json prev = json::parse(R"({"date": "2026-03-01", "entries": {"s": {"kind": "indices",
      "spec_hash": "h", "indices": {"method": "sobol", "outputs": [{"output": "y", "valid": true,
      "indices": [{"parameter": "a", "S1": 0.30, "S1_ci": [0.25, 0.35], "ST": 0.5, "ST_ci": [0.45, 0.55]},
                  {"parameter": "b", "S1": 0.10, "S1_ci": [0.05, 0.15], "ST": 0.2, "ST_ci": [0.15, 0.25]}]},
      {"output": "z", "valid": true, "indices": []}]}}}})");
  json cur = prev;
  cur["date"] = "2026-03-02";
  auto& idx = cur["entries"]["s"]["indices"]["outputs"][0]["indices"];
  idx[0]["S1"] = 0.34;  // moved, intervals overlap: not flagged
  idx[0]["S1_ci"] = {0.30, 0.38};
  idx[1]["ST"] = 0.40;  // moved beyond both intervals: flagged
  idx[1]["ST_ci"] = {0.33, 0.47};
  cur["entries"]["s"]["indices"]["outputs"][1]["valid"] = false;  // became invalid: flagged
  const json ch = compare_summaries(&prev, cur, {});
  ASSERT_EQ(ch["indices"].size(), 2u) << ch.dump(1);
  EXPECT_EQ(ch["indices"][0]["parameter"], "b");
  EXPECT_EQ(ch["indices"][0]["index"], "ST");
  EXPECT_EQ(ch["indices"][1]["output"], "z");
  EXPECT_EQ(ch["indices"][1]["index"], "status");
  EXPECT_EQ(ch["flagged"], 2);
  EXPECT_EQ(compare_summaries(&prev, prev, {})["flagged"], 0);
  EXPECT_EQ(compare_summaries(nullptr, cur, {})["flagged"], 0);
}

TEST(Report, HtmlIsWellFormedAndEveryPlotExists) {
  TempDir dir;
  const ReportResult a = build(parse_ok(small_config()), dir, "2026-03-01");
  ASSERT_TRUE(a.ok);
  const std::string html = slurp(a.html);
  // The plots the report promises, each kept as a file and embedded in the page.
  for (const char* plot :
       {"plots/map-heatmap-stage1.svg", "plots/map-heatmap-stage2.svg", "plots/map-curves.svg",
        "plots/figs-traces-1.svg", "plots/figs-traces-2.svg", "plots/sobol-heatmap.svg",
        "plots/sobol-bars-y.svg", "plots/sobol-convergence-y.svg", "plots/morris-heatmap.svg",
        "plots/morris-morris-y.svg"}) {
    EXPECT_NE(html.find(std::string("data-plot=\"") + plot + "\""), std::string::npos) << plot;
    EXPECT_TRUE(fs::exists(a.dir / plot)) << plot;
  }
  EXPECT_EQ(html.find("src=\"plots/"), std::string::npos) << "plots must be embedded";
  // Heat maps are discrete cells, one SVG path each: no bitmap that a browser would smooth
  // across the model rows (categories) or the outputs.
  for (const char* plot : {"plots/map-heatmap-stage1.svg", "plots/sobol-heatmap.svg"}) {
    const std::string svg = slurp(a.dir / plot);
    EXPECT_EQ(svg.find("<image"), std::string::npos) << plot;
  }
  EXPECT_EQ(html.find("http://"), std::string::npos) << "the page must not need the network";
  EXPECT_NE(html.find("Changed since last night"), std::string::npos);
  EXPECT_NE(html.find("Failed runs in total"), std::string::npos);
  // Strict tag balance, embedded SVGs that decode and parse as XML, and existing local links,
  // checked with Python's html.parser and xml.dom (tests/reports/check_report_html.py).
  if (std::system("python3 --version > /dev/null 2>&1") != 0) GTEST_SKIP() << "no python3";
  const std::string cmd = "python3 " STICKSLIP_SOURCE_DIR "/tests/reports/check_report_html.py '" +
                          a.html.string() + "' > '" + (dir / "check.out").string() + "'";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << "see stderr above";
  EXPECT_EQ(std::stoi(slurp(dir / "check.out")), 10);
}

TEST(Report, FailedRunsAreCountedAndShown) {
  TempDir dir;
  json doc = small_config();
  // F_S < F_C at the second point: an invalid run, counted and listed, never dropped.
  doc["studies"] = json::array({json::parse(R"({"id": "map", "kind": "map", "spec": {"name": "bad",
      "stages": [{"duration": 0.5}],
      "design": {"type": "grid", "axes": [{"name": "model", "values": ["karnopp"]},
                                          {"name": "F_S", "values": [11.1, 5.0]}]}}})")});
  const ReportResult a = build(parse_ok(doc), dir, "2026-03-01");
  ASSERT_TRUE(a.ok);
  EXPECT_EQ(a.summary_json["failures"]["total"], 1);
  EXPECT_EQ(a.summary_json["entries"]["map"]["failures"]["by_status"]["invalid"], 1);
  const std::string html = slurp(a.html);
  EXPECT_NE(html.find("design index 1 (invalid)"), std::string::npos);
}

}  // namespace
