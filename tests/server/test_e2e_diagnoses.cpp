// Diagnoses end to end with real processes: stickslipd on an ephemeral port; a synthetic
// dataset on disk submitted by `stickslip diagnose --server --wait --out`, whose diagnosis.json
// equals the server's stored result; a bad CSV sent with curl is a 422 naming /files/<name> and
// the line; SIGTERM during a diagnosis exits 0 and leaves it queued; the next start runs it.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <fstream>
#include <thread>

#include "daemon.h"
#include "process.h"
#include "stickslip/store/store.h"
#include "stickslip/measured/synth.h"
#include "test_support.h"

namespace stickslip::server {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using nlohmann::json;
using testing::CommandResult;
using testing::Process;
using testing::run_command;
using testing::slurp;
using testing::TempDir;

using testing::Curl;
using testing::curl;
using testing::Daemon;
using testing::kClientBin;

json get_diagnosis(const fs::path& dir, const std::string& url, const std::string& id) {
  const Curl c = curl(dir, {url + "/v1/diagnoses/" + id});
  EXPECT_EQ(c.status, 200) << c.body;
  return json::parse(c.body);
}

class DiagnosesEndToEnd : public ::testing::Test {
 protected:
  /// A short synthetic dataset on disk (2 LuGre runs of 6 s, vibration from 3 s, 500 Hz).
  fs::path write_dataset() {
    measured::SynthOptions o;
    o.model = engine::SimConfig::seed(engine::model_kind<engine::LuGre>, 0.0);
    measured::MeasuredConditions c;
    c.t_on = 3.0;
    c.duration = 6.0;
    o.runs = {c, c};
    o.runs[1].va = 4e-3;
    o.rate = 500.0;
    o.seed = 3;
    o.rtol = 1e-7;
    return measured::write_dataset(measured::synthesize(o), dir_ / "data");
  }
  std::vector<std::string> small_options() {
    return {"--models", "lugre", "--candidates", "viscous", "--max-evals-base", "12",
            "--max-evals-candidate", "10"};
  }
  TempDir dir_;
};

TEST_F(DiagnosesEndToEnd, ClientSubmitsWaitsAndWritesTheStoredResultAndCurlGetsProblems) {
  const fs::path manifest = write_dataset();
  Daemon d(dir_.path(), {"--diagnosis-threads", "2", "--diagnosis-grace", "0"});
  std::vector<std::string> argv = {kClientBin, "diagnose", manifest.string(), "--server", d.url(),
                                   "--wait", "--json", "--out", (dir_ / "out").string()};
  for (const auto& a : small_options()) argv.push_back(a);
  const CommandResult r = run_command(argv, dir_.path(), {}, 600s);
  ASSERT_EQ(r.code, 0) << r.err << r.out.substr(0, 500);
  const json resource = json::parse(r.out);
  EXPECT_EQ(resource["state"], "succeeded");
  const std::string id = resource["id"];
  // diagnosis.json written by the client = the result the server stored.
  const json written = json::parse(slurp(dir_ / "out" / "diagnosis.json"));
  EXPECT_EQ(written, resource["result"]);
  {
    auto store = store::Store::open(dir_ / "e2e.db", store::Store::Mode::kReadOnly);
    EXPECT_EQ(json::parse(*store.get_diagnosis(id)->result_json), written);
  }
  // The status command reads it back.
  const CommandResult s =
      run_command({kClientBin, "diagnosis", id, "--server", d.url()}, dir_.path());
  EXPECT_EQ(s.code, 0) << s.err;
  EXPECT_NE(s.out.find("succeeded"), std::string::npos) << s.out;
  EXPECT_NE(s.out.find("cause " + written["cause"].get<std::string>()), std::string::npos) << s.out;

  // curl with a broken CSV: 422 naming the file's pointer and the line; the server goes on.
  const json m = json::parse(slurp(manifest));
  const std::string f0 = m["runs"][0]["file"], f1 = m["runs"][1]["file"];
  std::string csv = slurp(dir_ / "data" / f0);
  const auto third_line = csv.find('\n', csv.find('\n') + 1) + 1;
  csv[third_line] = 'x';  // (csv.replace(pos, 1, "x") makes GCC 12 report a false -Wrestrict)
  const json bad = {{"manifest", m},
                    {"files", {{f0, csv}, {f1, slurp(dir_ / "data" / f1)}}}};
  std::ofstream(dir_ / "bad.json") << bad.dump();
  std::string data_arg = "@";
  data_arg += (dir_ / "bad.json").string();
  const Curl bad_post =
      curl(dir_.path(), {"-X", "POST", "-H", "Content-Type: application/json", "--data-binary",
                         data_arg, d.url() + "/v1/diagnoses"});
  EXPECT_EQ(bad_post.status, 422) << bad_post.body;
  const json p = json::parse(bad_post.body);
  EXPECT_EQ(p["errors"][0]["pointer"], "/files/" + f0) << bad_post.body;
  EXPECT_NE(p["errors"][0]["detail"].get<std::string>().find(f0 + ":3:"), std::string::npos)
      << bad_post.body;
  const Curl metrics = curl(dir_.path(), {d.url() + "/metrics"});
  EXPECT_EQ(metrics.status, 200);
  EXPECT_NE(metrics.body.find("stickslip_diagnoses{state=\"succeeded\"} 1"), std::string::npos);

  d.process().signal(SIGTERM);
  EXPECT_EQ(d.process().wait(60s), 0) << d.process().err();
}

TEST_F(DiagnosesEndToEnd, SigtermDuringADiagnosisExitsZeroAndTheNextStartRunsIt) {
  const fs::path manifest = write_dataset();
  std::string id;
  {
    Daemon d(dir_.path(), {"--diagnosis-threads", "2", "--diagnosis-grace", "0"});
    std::vector<std::string> argv = {kClientBin, "diagnose", manifest.string(), "--server",
                                     d.url()};
    for (const auto& a : small_options()) argv.push_back(a);
    const CommandResult r = run_command(argv, dir_.path());
    ASSERT_EQ(r.code, 0) << r.err;
    id = r.out.substr(0, r.out.find('\n'));
    ASSERT_TRUE(id.starts_with("dg-")) << r.out;
    json s;
    for (int i = 0; i < 2000; ++i) {
      s = get_diagnosis(dir_.path(), d.url(), id);
      if (s["state"] != "queued") break;
      std::this_thread::sleep_for(10ms);
    }
    ASSERT_EQ(s["state"], "running") << "finished before SIGTERM: " << s.dump().substr(0, 200);
    d.process().signal(SIGTERM);
    EXPECT_EQ(d.process().wait(30s), 0) << d.process().err();
  }
  {
    auto store = store::Store::open(dir_ / "e2e.db", store::Store::Mode::kReadOnly);
    EXPECT_EQ(store.get_diagnosis(id)->state, store::StudyState::kQueued);
  }
  Daemon d(dir_.path(), {"--diagnosis-threads", "2", "--diagnosis-grace", "0"});
  const CommandResult w =
      run_command({kClientBin, "diagnosis", id, "--server", d.url(), "--wait", "--json"},
                  dir_.path(), {}, 600s);
  ASSERT_EQ(w.code, 0) << w.err;
  const json done = json::parse(w.out);
  EXPECT_EQ(done["state"], "succeeded");
  EXPECT_TRUE(done["result"].is_object());
  d.process().signal(SIGTERM);
  EXPECT_EQ(d.process().wait(60s), 0);
}

}  // namespace
}  // namespace stickslip::server
