// Fills a store with one succeeded study of a given spec whose runs are made up, not simulated,
// for bench/dashboard_open.sh: the dashboard's page of a 50,000-run study is timed on the store
// a real study would leave (the same rows, params and stage metrics), in seconds instead of the
// eight minutes the runs would take. Metrics are smooth functions of the design point plus a
// little deterministic scatter, so the charts look like a map.
//
//   dashboard_fill SPEC.json DB   -> prints the study id
#include <cmath>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>

#include <CLI/CLI.hpp>

#include "stickslip/common/json_schema.h"
#include "stickslip/store/store.h"
#include "stickslip/studies/spec.h"

using namespace stickslip::store;
using stickslip::studies::DesignPoint;
using stickslip::studies::parse_study;
using stickslip::studies::ParseResult;
using stickslip::studies::StudySpec;

int main(int argc, char** argv) {
  std::string spec_path, db;
  CLI::App app{"Fills DB with one succeeded study of SPEC whose runs are made up; prints its id"};
  app.add_option("SPEC", spec_path, "study spec (JSON)")->required()->check(CLI::ExistingFile);
  app.add_option("DB", db, "the store to fill")->required();
  CLI11_PARSE(app, argc, argv);
  std::ifstream in(spec_path);
  std::stringstream text;
  text << in.rdbuf();
  const ParseResult parsed = parse_study(text.str());
  if (!parsed.ok()) {
    std::cerr << "dashboard_fill: " << stickslip::common::to_string(parsed.errors) << "\n";
    return 2;
  }
  const StudySpec& spec = *parsed.spec;
  auto store = Store::open(db);
  NewStudy ns;
  ns.name = spec.name();
  ns.spec_json = spec.canonical_json();
  ns.spec_hash = param_hash(ns.spec_json);
  ns.total_runs = static_cast<std::int64_t>(spec.run_count());
  const std::string id = store.create_study(ns).study.id;
  store.set_study_state(id, StudyState::kRunning);
  {
    WriterOptions wo;
    wo.max_batch = 5000;
    auto writer = RunWriter::open(db, wo);
    for (std::size_t i = 0; i < spec.run_count(); ++i) {
      const DesignPoint p = spec.point(i);
      RunRecord r;
      r.study_id = id;
      r.design_index = static_cast<std::int64_t>(i);
      r.params_json = spec.canonical_point_json(p);
      r.param_hash = param_hash(r.params_json);
      if (!p.model.empty()) r.model = p.model;
      r.va_over_vd = p.value("va_over_vd");
      const double va = r.va_over_vd.value_or(0.0);
      const double kd = p.value("k_d").value_or(11700.0);
      const double scatter = 0.02 * std::sin(12.9898 * static_cast<double>(i));
      // A level per model (its position in the registry), so the models' curves differ.
      double m = 1.0;
      for (const auto& t : stickslip::engine::all_model_traits())
        if (p.model == t.info->name) m = 0.8 + 0.15 * static_cast<double>(t.kind);
      r.steps = 100000;
      r.wall_time_s = 0.02;
      r.t_end = 4.0;
      for (int s = 1; s <= 2; ++s) {
        StageMetricsRecord st;
        st.stage = s;
        st.t_start = 2.0 * (s - 1);
        st.t_end = 2.0 * s;
        const double reduce = s == 1 ? 1.0 : std::exp(-va / 2.0);
        st.amplitude = m * 2.7 * reduce * (kd / 11700.0) + scatter;
        st.amplitude_raw = st.amplitude;
        st.mean_force = 9.6 - 0.3 * (1.0 - reduce) + scatter;
        st.mean_friction = st.mean_force;
        st.slip_events = 20;
        st.mean_period = 0.1;
        r.stages.push_back(st);
      }
      writer.add(std::move(r));
    }
    writer.flush();
  }
  store.set_study_state(id, StudyState::kSucceeded);
  std::cout << id << "\n";
  return 0;
}
