// End to end with real processes and real HTTP: stickslipd on an ephemeral port, driven by the
// `stickslip` client binary and by curl; results checked against the SQLite store; SIGKILL in
// the middle of a study, then a restart, gives exactly one result per run; SIGTERM exits 0,
// loses nothing finished and leaves the study to resume.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <set>
#include <thread>

#include "daemon.h"
#include "process.h"
#include "stickslip/store/store.h"
#include "test_support.h"

namespace stickslip::server {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using nlohmann::json;
using testing::CommandResult;
using testing::Process;
using testing::run_command;
using testing::study_json;
using testing::slurp;
using testing::TempDir;

using testing::Curl;
using testing::curl;
using testing::Daemon;
using testing::kClientBin;
using testing::kServerBin;


json get_json(const fs::path& dir, const std::string& url) {
  const Curl c = curl(dir, {url});
  EXPECT_EQ(c.status, 200) << url << ": " << c.body;
  return json::parse(c.body);
}

/// Polls GET /v1/studies/{id} until pred(study) or timeout.
json poll_until(const fs::path& dir, const std::string& url, const std::string& id,
                const std::function<bool(const json&)>& pred, std::chrono::seconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  json s;
  while (std::chrono::steady_clock::now() < deadline) {
    s = get_json(dir, url + "/v1/studies/" + id);
    if (pred(s)) return s;
    std::this_thread::sleep_for(50ms);
  }
  ADD_FAILURE() << "timed out; last: " << s.dump();
  return s;
}

/// Direct read of the store, independent of the server.
struct StoreFacts {
  std::int64_t runs = 0, distinct = 0, min_index = -1, max_index = -1;
  std::string integrity;
};
StoreFacts store_facts(const fs::path& db, const std::string& id) {
  sqlite3* h = nullptr;
  sqlite3_open_v2(db.c_str(), &h, SQLITE_OPEN_READONLY, nullptr);
  StoreFacts f;
  auto one = [&](const std::string& sql, auto fn) {
    sqlite3_stmt* st = nullptr;
    sqlite3_prepare_v2(h, sql.c_str(), -1, &st, nullptr);
    if (sqlite3_step(st) == SQLITE_ROW) fn(st);
    sqlite3_finalize(st);
  };
  one("SELECT count(*), count(DISTINCT design_index), min(design_index), max(design_index) "
      "FROM runs WHERE study_id = '" + id + "'",
      [&](sqlite3_stmt* st) {
        f.runs = sqlite3_column_int64(st, 0);
        f.distinct = sqlite3_column_int64(st, 1);
        f.min_index = sqlite3_column_int64(st, 2);
        f.max_index = sqlite3_column_int64(st, 3);
      });
  one("PRAGMA integrity_check", [&](sqlite3_stmt* st) {
    f.integrity = reinterpret_cast<const char*>(sqlite3_column_text(st, 0));
  });
  sqlite3_close(h);
  return f;
}

class EndToEnd : public ::testing::Test {
 protected:
  fs::path spec_file(const std::string& text, const std::string& name = "spec.json") {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p;
  }
  TempDir dir_;
};

TEST_F(EndToEnd, ClientAndCurlSubmitPollAndFetchTheMapWhichMatchesTheStore) {
  Daemon d(dir_.path());
  // 1. The client binary: submit --wait prints the id and exits 0 when the study succeeded.
  const CommandResult sub = run_command(
      {kClientBin, "submit", spec_file(study_json("e2e-client", 3, 0.5)).string(), "--wait",
       "--server", d.url()},
      dir_.path());
  ASSERT_EQ(sub.code, 0) << sub.out << sub.err;
  const std::string id1 = sub.out.substr(0, sub.out.find('\n'));
  ASSERT_TRUE(id1.starts_with("st-")) << sub.out;
  EXPECT_NE(sub.err.find("6/6 runs"), std::string::npos) << sub.err;  // plain progress lines

  // 2. curl: 202 + Location, then poll until it succeeded.
  const Curl post = curl(dir_.path(), {"-X", "POST", "-H", "Content-Type: application/json",
                                       "--data-binary",
                                       "@" + spec_file(study_json("e2e-curl", 2, 0.5)).string(),
                                       d.url() + "/v1/studies"});
  ASSERT_EQ(post.status, 202) << post.body;
  const std::string id2 = json::parse(post.body)["id"];
  EXPECT_NE(post.headers.find("Location: /v1/studies/" + id2), std::string::npos) << post.headers;
  const json done = poll_until(dir_.path(), d.url(), id2,
                               [](const json& s) { return s["state"] == "succeeded"; }, 80s);
  EXPECT_EQ(done["progress"], json({{"total", 4}, {"done", 4}, {"ok", 4}, {"failed", 0}}));

  // 3. The map (client, JSON) against the store, read without the server.
  const fs::path map_file = dir_ / "map.json";
  const CommandResult map = run_command({kClientBin, "map", id1, "--server", d.url(), "--format",
                                         "json", "--out", map_file.string()},
                                        dir_.path());
  ASSERT_EQ(map.code, 0) << map.err;
  const json m = json::parse(slurp(map_file));
  auto store = store::Store::open(dir_ / "e2e.db", store::Store::Mode::kReadOnly);
  const auto runs = store.get_runs(id1);
  ASSERT_EQ(runs.size(), 6u);
  std::size_t checked = 0;
  for (const auto& row : m["rows"]) {
    for (const auto& [model, cell] : row["cells"].items()) {
      const auto run = std::find_if(runs.begin(), runs.end(), [&](const auto& r) {
        return r.design_index == cell["design_index"].get<std::int64_t>();
      });
      ASSERT_NE(run, runs.end()) << cell.dump();
      EXPECT_EQ(run->model, model);
      EXPECT_EQ(row["key"]["va_over_vd"].get<double>(), *run->va_over_vd);
      EXPECT_EQ(cell["status"], run->status);
      for (const auto& st : run->stages) {
        const json& a = cell["amplitude"][st.stage - 1];
        if (std::isnan(st.amplitude)) EXPECT_TRUE(a.is_null());
        else EXPECT_EQ(a.get<double>(), st.amplitude);  // bit for bit through JSON
      }
      ++checked;
    }
  }
  EXPECT_EQ(checked, 6u);
  // ... and the table and CSV forms work too.
  const CommandResult table = run_command({kClientBin, "map", id1, "--server", d.url()},
                                          dir_.path());
  EXPECT_EQ(table.code, 0) << table.err;
  EXPECT_NE(table.out.find("| lugre"), std::string::npos) << table.out;
  EXPECT_NE(table.out.find("missing 0, failed 0"), std::string::npos) << table.out;
  const Curl csv = curl(dir_.path(), {"-H", "Accept: text/csv", d.url() + "/v1/studies/" + id1 + "/runs"});
  EXPECT_EQ(csv.status, 200);
  EXPECT_EQ(std::count(csv.body.begin(), csv.body.end(), '\n'), 1 + 6) << csv.body;

  // 4. status / list / runs through the client.
  const CommandResult status = run_command(
      {kClientBin, "status", id2, "--server", d.url(), "--json"}, dir_.path());
  EXPECT_EQ(status.code, 0);
  EXPECT_EQ(json::parse(status.out)["state"], "succeeded");
  const CommandResult list = run_command({kClientBin, "list", "--server", d.url()}, dir_.path());
  EXPECT_NE(list.out.find(id1), std::string::npos);
  EXPECT_NE(list.out.find(id2), std::string::npos);

  d.process().signal(SIGTERM);
  EXPECT_EQ(d.process().wait(30s), 0);
}

TEST_F(EndToEnd, EveryBadRequestIsA4xxProblemAndTheServerKeepsServing) {
  Daemon d(dir_.path(), {"--max-runs", "20", "--max-body", "2048"});
  const std::string studies = d.url() + "/v1/studies";
  const std::string ct = "Content-Type: application/json";
  struct Case {
    std::string what;
    std::vector<std::string> args;
    int status;
    std::string field;  // a pointer / parameter / header expected in the problem ("" = none)
  };
  const std::string big(4000, ' ');
  const std::vector<Case> cases = {
      {"malformed JSON", {"-X", "POST", "-H", ct, "--data", "{\"name\": ", studies}, 400, ""},
      {"wrong content type", {"-X", "POST", "-H", "Content-Type: text/plain", "--data", "{}", studies}, 415, "Content-Type"},
      {"unknown field", {"-X", "POST", "-H", ct, "--data", R"({"name":"x","bogus":1})", studies}, 422, "/bogus"},
      {"wrong type", {"-X", "POST", "-H", ct, "--data", R"({"name":"x","base":{"m":"heavy"}})", studies}, 422, "/base/m"},
      {"negative mass", {"-X", "POST", "-H", ct, "--data", R"({"name":"x","base":{"m":-1}})", studies}, 422, "/base/m"},
      {"unknown model", {"-X", "POST", "-H", ct, "--data", R"({"name":"x","base":{"model":"nope"}})", studies}, 422, "/base/model"},
      {"over the run limit", {"-X", "POST", "-H", ct, "--data", study_json("big", 11, 0.5), studies}, 422, "/design"},
      {"body over the size limit", {"-X", "POST", "-H", ct, "--data", "{\"name\":\"x\"" + big + "}", studies}, 413, ""},
      {"unknown route", {d.url() + "/v1/nothing"}, 404, ""},
      {"wrong method", {"-X", "DELETE", studies}, 405, ""},
      {"unknown study id", {studies + "/st-00000000000000000000"}, 404, ""},
      {"bad page size", {studies + "?page_size=0"}, 400, "page_size"},
  };
  for (const auto& c : cases) {
    const Curl r = curl(dir_.path(), c.args);
    EXPECT_EQ(r.status, c.status) << c.what << ": " << r.body;
    EXPECT_NE(r.headers.find("application/problem+json"), std::string::npos) << c.what;
    const json p = json::parse(r.body, nullptr, false);
    ASSERT_TRUE(p.is_object()) << c.what << ": " << r.body;
    EXPECT_EQ(p["status"], c.status) << c.what;
    if (!c.field.empty()) {
      EXPECT_NE(r.body.find("\"" + c.field + "\""), std::string::npos) << c.what << ": " << r.body;
    }
    EXPECT_EQ(curl(dir_.path(), {d.url() + "/healthz"}).status, 200) << "after " << c.what;
  }
  // Idempotency-Key reused with another body.
  const std::string key = "Idempotency-Key: k1";
  EXPECT_EQ(curl(dir_.path(), {"-X", "POST", "-H", ct, "-H", key, "--data",
                               study_json("a", 2, 0.5), studies}).status, 202);
  const Curl again = curl(dir_.path(), {"-X", "POST", "-H", ct, "-H", key, "--data",
                                        study_json("a", 2, 0.5), studies});
  EXPECT_EQ(again.status, 202);
  EXPECT_NE(again.headers.find("Idempotent-Replayed: true"), std::string::npos);
  const Curl other = curl(dir_.path(), {"-X", "POST", "-H", ct, "-H", key, "--data",
                                        study_json("b", 2, 0.5), studies});
  EXPECT_EQ(other.status, 422) << other.body;
  EXPECT_NE(other.body.find("Idempotency-Key"), std::string::npos);
  // Nothing bad was stored: only the one study.
  EXPECT_EQ(get_json(dir_.path(), studies)["studies"].size(), 1u);

  // The client shows the field paths and exits 2 on an invalid spec.
  const CommandResult bad = run_command(
      {kClientBin, "submit",
       spec_file(R"({"name":"x","base":{"m":-1,"model":"nope"}})", "bad.json").string(),
       "--server", d.url()},
      dir_.path());
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find("/base/m: "), std::string::npos) << bad.err;
  EXPECT_NE(bad.err.find("/base/model: "), std::string::npos) << bad.err;

  d.process().signal(SIGTERM);
  EXPECT_EQ(d.process().wait(30s), 0);
}

TEST_F(EndToEnd, TokenIsRequiredForChangesAndClientTakesItFromTheEnvironment) {
  Daemon d(dir_.path(), {}, {"STICKSLIP_TOKEN=t0k3n"});
  const fs::path spec = spec_file(study_json("tok", 2, 0.5));
  const Curl none = curl(dir_.path(), {"-X", "POST", "-H", "Content-Type: application/json",
                                       "--data-binary", "@" + spec.string(), d.url() + "/v1/studies"});
  EXPECT_EQ(none.status, 401);
  const Curl wrong = curl(dir_.path(), {"-X", "POST", "-H", "Content-Type: application/json",
                                        "-H", "Authorization: Bearer nope", "--data-binary",
                                        "@" + spec.string(), d.url() + "/v1/studies"});
  EXPECT_EQ(wrong.status, 403);
  EXPECT_EQ(curl(dir_.path(), {d.url() + "/v1/studies"}).status, 200);  // reads are open

  const CommandResult no_token =
      run_command({kClientBin, "submit", spec.string(), "--server", d.url()}, dir_.path(),
                  {"STICKSLIP_TOKEN="});
  EXPECT_EQ(no_token.code, 2) << no_token.err;
  EXPECT_NE(no_token.err.find("401"), std::string::npos) << no_token.err;
  const CommandResult ok =
      run_command({kClientBin, "submit", spec.string(), "--server", d.url()}, dir_.path(),
                  {"STICKSLIP_TOKEN=t0k3n"});
  EXPECT_EQ(ok.code, 0) << ok.err;
  d.process().signal(SIGTERM);
  EXPECT_EQ(d.process().wait(30s), 0);
}

TEST_F(EndToEnd, BadPriorityOptionsExit2NamingTheValue) {
  for (const std::vector<std::string>& bad :
       {std::vector<std::string>{"--io-nice", "25"}, std::vector<std::string>{"--worker-nice", "-3"}}) {
    std::vector<std::string> argv = {kServerBin, "--db", (dir_ / "bad.db").string(), "--port", "0"};
    argv.insert(argv.end(), bad.begin(), bad.end());
    const CommandResult r = run_command(argv, dir_.path());
    EXPECT_EQ(r.code, 2) << bad[0] << ": " << r.err;
    EXPECT_NE(r.err.find("got " + bad[1]), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(bad[0] == "--io-nice" ? "io_nice" : "nice"), std::string::npos) << r.err;
  }
}

TEST_F(EndToEnd, ClientExitCodes) {
  // 3: nothing listens there (port 1 is privileged and unused here).
  const CommandResult down =
      run_command({kClientBin, "status", "st-x", "--server", "http://127.0.0.1:1"}, dir_.path());
  EXPECT_EQ(down.code, 3) << down.err;
  // 2: a spec file that does not exist, a bad URL.
  EXPECT_EQ(run_command({kClientBin, "submit", (dir_ / "missing.json").string()}, dir_.path()).code, 2);
  EXPECT_EQ(run_command({kClientBin, "list", "--server", "ftp://x"}, dir_.path()).code, 2);
  // 4: a cancelled study.
  Daemon d(dir_.path());
  const CommandResult sub = run_command(
      {kClientBin, "submit", spec_file(study_json("slow", 40, 2.0)).string(), "--server", d.url()},
      dir_.path());
  ASSERT_EQ(sub.code, 0) << sub.err;
  const std::string id = sub.out.substr(0, sub.out.find('\n'));
  const CommandResult cancel =
      run_command({kClientBin, "cancel", id, "--server", d.url()}, dir_.path());
  EXPECT_EQ(cancel.code, 0) << cancel.err;
  const CommandResult wait = run_command({kClientBin, "wait", id, "--server", d.url()}, dir_.path());
  EXPECT_EQ(wait.code, 4) << wait.out << wait.err;
  EXPECT_NE(wait.out.find("cancelled"), std::string::npos) << wait.out;
  d.process().signal(SIGTERM);
  EXPECT_EQ(d.process().wait(60s), 0);
}

/// A study long enough to be interrupted: 2 models x 40 va_over_vd, 2 x 1 s stages (80 runs,
/// a few seconds on 2 cores; the runner commits every 0.5 s).
class Interrupted : public EndToEnd {
 protected:
  std::string submit(Daemon& d) {
    const Curl post = curl(dir_.path(), {"-X", "POST", "-H", "Content-Type: application/json",
                                         "--data-binary",
                                         "@" + spec_file(study_json("long", 40, 1.0)).string(),
                                         d.url() + "/v1/studies"});
    EXPECT_EQ(post.status, 202) << post.body;
    return json::parse(post.body)["id"];
  }
};

TEST_F(Interrupted, SigkillMidStudyThenRestartGivesExactlyOneResultPerRun) {
  std::string id;
  {
    Daemon d(dir_.path());
    id = submit(d);
    const json s = poll_until(dir_.path(), d.url(), id, [](const json& s) {
      return s["progress"]["done"].get<int>() > 0;
    }, 80s);
    ASSERT_LT(s["progress"]["done"].get<int>(), 80) << "study finished before the kill";
    d.process().signal(SIGKILL);
    EXPECT_EQ(d.process().wait(10s), 128 + SIGKILL);
  }
  const StoreFacts mid = store_facts(dir_ / "e2e.db", id);
  EXPECT_EQ(mid.integrity, "ok");
  EXPECT_LT(mid.runs, 80);
  Daemon d(dir_.path());  // resumes by itself
  const json s = poll_until(dir_.path(), d.url(), id,
                            [](const json& s) { return s["state"] == "succeeded"; }, 300s);
  EXPECT_EQ(s["progress"]["done"], 80);
  const StoreFacts f = store_facts(dir_ / "e2e.db", id);
  EXPECT_EQ(f.integrity, "ok");
  EXPECT_EQ(f.runs, 80);
  EXPECT_EQ(f.distinct, 80);
  EXPECT_EQ(f.min_index, 0);
  EXPECT_EQ(f.max_index, 79);
  d.process().signal(SIGTERM);
  EXPECT_EQ(d.process().wait(60s), 0);
}

TEST_F(Interrupted, SigtermExitsZeroKeepsFinishedRunsAndTheStudyResumes) {
  std::string id;
  std::int64_t seen_done = 0;
  {
    Daemon d(dir_.path());
    id = submit(d);
    const json s = poll_until(dir_.path(), d.url(), id, [](const json& s) {
      return s["progress"]["done"].get<int>() > 0;
    }, 80s);
    seen_done = s["progress"]["done"];
    ASSERT_LT(seen_done, 80) << "study finished before SIGTERM";
    d.process().signal(SIGTERM);
    EXPECT_EQ(d.process().wait(60s), 0) << d.process().err();
  }
  // Read-only: a read-write Store would make this process the store's writer (docs/store.md)
  // and the next stickslipd would refuse to start.
  auto store = store::Store::open(dir_ / "e2e.db", store::Store::Mode::kReadOnly);
  const auto rec = store.get_study(id);
  EXPECT_EQ(rec->state, store::StudyState::kQueued) << "not left to resume";
  const StoreFacts mid = store_facts(dir_ / "e2e.db", id);
  EXPECT_EQ(mid.integrity, "ok");
  EXPECT_GE(mid.runs, seen_done) << "runs reported done were lost";
  Daemon d(dir_.path());
  const json s = poll_until(dir_.path(), d.url(), id,
                            [](const json& s) { return s["state"] == "succeeded"; }, 300s);
  const StoreFacts f = store_facts(dir_ / "e2e.db", id);
  EXPECT_EQ(f.runs, 80);
  EXPECT_EQ(f.distinct, 80);
  d.process().signal(SIGTERM);
  EXPECT_EQ(d.process().wait(60s), 0);
}

}  // namespace
}  // namespace stickslip::server
