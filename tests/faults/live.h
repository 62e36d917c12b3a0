#pragma once
// The fault-injection cases that drive real processes (a stickslipd over dir/e2e.db, the
// stickslip binary, the sqlite3 shell): the jobs they submit, what the API confirmed of each,
// and the checks of the file against those confirmations.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "faults/file_facts.h"
#include "server/daemon.h"
#include "stickslip/measured/synth.h"

namespace stickslip::testing {

namespace fs = std::filesystem;
using server::testing::Curl;
using server::testing::curl;
using server::testing::Daemon;
using server::testing::slurp;
using server::testing::study_json;

/// The body of POST /v1/diagnoses for a small synthetic dataset (2 LuGre runs of 3 s at 250 Hz,
/// one base model and one candidate with small budgets: tens of seconds on a busy machine).
inline std::string diagnosis_body(const fs::path& dir) {
  measured::SynthOptions o;
  o.model = engine::SimConfig::seed(engine::model_kind<engine::LuGre>, 0.0);
  measured::MeasuredConditions c;
  c.t_on = 1.5;
  c.duration = 3.0;
  o.runs = {c, c};
  o.runs[1].va = 4e-3;
  o.rate = 250.0;
  o.seed = 5;
  o.rtol = 1e-7;
  const fs::path manifest = measured::write_dataset(measured::synthesize(o), dir / "data");
  nlohmann::json m = nlohmann::json::parse(slurp(manifest));
  nlohmann::json files = nlohmann::json::object();
  for (const auto& run : m["runs"]) {
    const std::string f = run["file"];
    files[f] = slurp(dir / "data" / f);
  }
  return nlohmann::json({{"manifest", m},
                         {"files", files},
                         {"options",
                          {{"models", {"lugre"}},
                           {"candidates", {"viscous"}},
                           {"max_evals_base", 12},
                           {"max_evals_candidate", 10},
                           {"whole_run_holdout", false}}}})
      .dump();
}

/// A job (study or diagnosis) submitted through the API, and what the API confirmed of it.
struct Job {
  std::string collection;  ///< "studies" or "diagnoses"
  std::string key;         ///< its Idempotency-Key
  fs::path body;           ///< the request body's file
  std::string id;          ///< from the 202 (empty: not confirmed)
  std::int64_t total = 0;  ///< a study's runs
  std::int64_t done = 0;   ///< the largest progress.done the API served
  bool succeeded = false;  ///< the API served state succeeded
  std::string ended;       ///< "failed" or "cancelled" when the API served that state
};

inline Job make_job(std::string collection, std::string key, fs::path body) {
  Job j;
  j.collection = std::move(collection);
  j.key = std::move(key);
  j.body = std::move(body);
  return j;
}

/// POSTs the job (again: the same key must give the same id, never a second job). Returns the
/// HTTP status; records the id of a 202/200.
inline int post_job(const fs::path& dir, const std::string& url, Job& job) {
  // Built by appending: g++ 12 warns (-Wrestrict, a false positive) on "literal" + string here.
  std::string key_header = "Idempotency-Key: ", body_arg = "@";
  key_header += job.key;
  body_arg += job.body.string();
  const Curl c = curl(dir, {"-X", "POST", "-H", "Content-Type: application/json", "-H", key_header,
                            "--data-binary", body_arg, url + "/v1/" + job.collection});
  if (c.status == 202 || c.status == 200) {
    const auto j = nlohmann::json::parse(c.body);
    const std::string id = j.at("id");
    if (!job.id.empty()) {
      EXPECT_EQ(id, job.id) << "a replayed POST made another " << job.collection;
    }
    job.id = id;
    if (job.collection == "studies") job.total = j.at("progress").at("total");
  } else {
    ADD_FAILURE() << "POST " << job.collection << ": " << c.status << " " << c.body;
  }
  return c.status;
}

/// GETs the job and records what the API confirmed (nothing when the request fails: the server
/// may be gone).
inline void poll_job(const fs::path& dir, const std::string& url, Job& job) {
  if (job.id.empty()) return;
  const std::vector<std::string> argv = {"curl", "-sS", "--max-time", "5",
                                         url + "/v1/" + job.collection + "/" + job.id};
  const auto r = server::testing::run_command(argv, dir);
  if (r.code != 0) return;
  const auto j = nlohmann::json::parse(r.out, nullptr, false);
  if (j.is_discarded() || !j.contains("state")) return;
  // A study's progress counts its confirmed runs; a diagnosis's (null or phase, evaluations,
  // time left) confirms nothing stored.
  if (job.collection == "studies" && j.contains("progress") && j["progress"].is_object() &&
      j["progress"].contains("done") && j["progress"]["done"].is_number_integer())
    job.done = std::max<std::int64_t>(job.done, j["progress"]["done"].get<std::int64_t>());
  if (j["state"] == "succeeded") job.succeeded = true;
  if (j["state"] == "failed" || j["state"] == "cancelled") job.ended = j["state"];
}

/// The file holds everything the API confirmed of the jobs, and is sound (file_facts.h).
inline void expect_jobs_kept(const fs::path& db, const std::vector<Job>& jobs,
                             const std::string& label) {
  SCOPED_TRACE(label);
  expect_sound_file(db, label);
  RawDb raw(db);
  for (const Job& job : jobs) {
    if (job.id.empty()) continue;
    const std::string q = quoted(job.id);
    const std::string table = job.collection == "studies" ? "studies" : "diagnoses";
    ASSERT_EQ(raw.integer("SELECT count(*) FROM " + table + " WHERE id = " + q), 1)
        << "confirmed " << job.id << " is lost";
    const std::string state = raw.text("SELECT state FROM " + table + " WHERE id = " + q);
    if (job.succeeded) {
      EXPECT_EQ(state, "succeeded") << job.id;
    }
    if (job.collection == "studies") {
      const auto runs = raw.integer("SELECT count(*) FROM runs WHERE study_id = " + q);
      EXPECT_GE(runs, job.done) << job.id << ": the API confirmed " << job.done << " runs";
      if (job.succeeded) {
        EXPECT_EQ(runs, job.total) << job.id;
      }
    } else if (state == "succeeded") {
      EXPECT_NE(raw.text("SELECT result_json FROM diagnoses WHERE id = " + q), "NULL") << job.id;
    }
  }
}

/// Polls every job until all succeeded (true), one failed or was cancelled, or timeout.
inline bool wait_all_succeeded(const fs::path& dir, const std::string& url, std::vector<Job>& jobs,
                               std::chrono::seconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    bool all = true;
    for (Job& job : jobs) {
      if (!job.succeeded) poll_job(dir, url, job);
      if (!job.ended.empty()) {  // it will never succeed: say so now, not at the timeout
        ADD_FAILURE() << job.collection << " " << job.id << " ended " << job.ended;
        return false;
      }
      all = all && job.succeeded;
    }
    if (all) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  return false;
}

}  // namespace stickslip::testing
