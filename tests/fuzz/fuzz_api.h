#pragma once
// The HTTP harnesses' API (fuzz_http.cpp, fuzz_page_token.cpp): server::Api over a store in a
// fresh temporary directory with a few studies, runs and diagnoses of fixed ids, and the
// properties every response must have.
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "fuzz_support.h"
#include "stickslip/server/api.h"
#include "stickslip/server/http.h"
#include "stickslip/store/store.h"

namespace stickslip::fuzz {

/// A fresh directory, removed with its contents when the process exits normally.
inline const std::filesystem::path& scratch_dir() {
  static const std::filesystem::path dir = [] {
    std::string tmpl = (std::filesystem::temp_directory_path() / "stickslip-fuzz-XXXXXX").string();
    if (mkdtemp(tmpl.data()) == nullptr) std::abort();
    std::atexit([] {
      std::error_code ec;
      std::filesystem::remove_all(scratch_dir(), ec);
    });
    return std::filesystem::path(tmpl);
  }();
  return dir;
}

inline constexpr const char* kToken = "fuzz-token";

/// A store with 7 studies st-fuzz0..6 (st-fuzz0 with 23 runs, succeeded) and 3 diagnoses
/// dg-fuzz0..2 (dg-fuzz0 succeeded with a result and a trace); the ids, in creation order.
struct Population {
  std::vector<std::string> studies, diagnoses;
};

inline Population populate(const std::filesystem::path& db) {
  Population p;
  auto s = store::Store::open(db);
  for (int i = 0; i < 7; ++i) {
    store::NewStudy ns;
    ns.id = "st-fuzz" + std::to_string(i);  // fixed ids, so that seeds can name them
    ns.name = "fuzz-" + std::to_string(i);
    ns.spec_json = R"({"name":"fuzz","stages":[{"duration":1},{"duration":1}]})";
    ns.spec_hash = store::param_hash(ns.spec_json);
    ns.total_runs = 23;
    p.studies.push_back(s.create_study(ns).study.id);
  }
  {
    auto w = store::RunWriter::open(db);
    for (std::int64_t i = 0; i < 23; ++i) {
      store::RunRecord r;
      r.study_id = p.studies[0];
      r.design_index = i;
      r.params_json = R"({"model":"lugre","va_over_vd":)" + std::to_string(i) + "}";
      r.param_hash = store::param_hash(r.params_json);
      r.model = "lugre";
      r.va_over_vd = static_cast<double>(i);
      r.status = i % 7 == 6 ? "diverged" : "ok";
      r.steps = 100;
      for (int st = 1; st <= 2; ++st) {
        store::StageMetricsRecord m;
        m.stage = st;
        m.t_end = st;
        m.amplitude = 0.1 * static_cast<double>(i);
        r.stages.push_back(m);
      }
      if (i % 5 == 0) r.trace = {{0, 1, 1, 0, 0, 0}, {0.1, 1.5, 1.2, 1e-4, 1e-3, 0}};
      w.add(r);
    }
    w.flush();
  }
  s.set_study_state(p.studies[0], store::StudyState::kSucceeded);
  for (int i = 0; i < 3; ++i) {
    store::NewDiagnosis nd;
    nd.id = "dg-fuzz" + std::to_string(i);
    nd.name = "fuzz-diagnosis-" + std::to_string(i);
    nd.request_json = R"({"manifest":{"name":"x","runs":[]},"files":{}})";
    nd.request_hash = store::param_hash(nd.request_json);
    p.diagnoses.push_back(s.create_diagnosis(nd).diagnosis.id);
  }
  store::DiagnosisTrace tr;
  tr.run = "run0";
  tr.t = {0, 0.1, 0.2};
  tr.measured = {1, 2, 3};
  tr.base = {1, 2, 2.5};
  s.set_diagnosis_state(p.diagnoses[0], store::StudyState::kRunning);
  s.finish_diagnosis(p.diagnoses[0], store::StudyState::kSucceeded,
                     R"({"cause":"none","runs":[{"name":"run0"}]})", std::nullopt, {tr});
  return p;
}

/// The Api of the harnesses over the populated store (built once per process).
struct ApiFixture {
  std::filesystem::path db;
  Population population;
  std::unique_ptr<server::Api> api;
};

inline ApiFixture& api_fixture() {
  static ApiFixture* f = [] {
    auto* out = new ApiFixture;  // lives as long as the process (reachable: no leak reported)
    out->db = scratch_dir() / "fuzz.db";
    out->population = populate(out->db);
    server::ApiOptions o;
    o.db = out->db;
    o.token = kToken;
    o.study_cache_ttl = std::chrono::milliseconds(0);  // every request reads the store
    out->api = std::make_unique<server::Api>(o);
    return out;
  }();
  return *f;
}

/// What every response of the API must be: a known status, never a 5xx (a 5xx means the server
/// or its store failed, never the request: api.h), and a problem+json body that is JSON with the
/// response's status for every 4xx.
inline void check_response(const server::Request& req, const server::Response& res) {
  const std::string where = req.method + " " + req.target.substr(0, 200) + " -> " +
                            std::to_string(res.status) + " " + res.body.substr(0, 300);
  FUZZ_CHECK((res.status >= 200 && res.status < 300) || res.status == 304 ||
                 (res.status >= 400 && res.status < 500),
             where);
  const auto type = res.header("Content-Type");
  if (res.status >= 400) {
    FUZZ_CHECK(type && *type == "application/problem+json", where);
    const auto j = nlohmann::json::parse(res.body, nullptr, false);
    FUZZ_CHECK(j.is_object() && j.value("status", 0) == res.status, where);
    FUZZ_CHECK(j.contains("title") && j.contains("detail") && j.contains("type"), where);
  } else if (type && type->starts_with("application/json")) {
    FUZZ_CHECK(!nlohmann::json::parse(res.body, nullptr, false).is_discarded(), where);
  }
}

}  // namespace stickslip::fuzz
