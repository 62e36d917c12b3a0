// I/O errors injected into the store, in the spirit of SQLite's own "ioerr" tests: the same
// small workload (create a store, a study, 12 runs in batches of 4, the study's state, a
// diagnosis with its result and traces) runs once per N, with the N-th write, fsync or lock of
// the process failing (tests/support/fault_vfs.h), once or from then on (a disk that filled up).
// N goes over the range of calls the workload makes, so the error hits every step of it:
// creating the file, the schema, each batch's WAL frames, commits, checkpoints on close.
//
// After each run, with the faults off:
//  - every record whose call returned (a committed batch, the study, the diagnosis and its
//    outcome) is in the file, with the content it was written with;
//  - integrity_check is ok, no duplicates, no partial run (file_facts.h);
//  - the workload completes when run again on the same file, and the file then holds exactly
//    what a run without faults wrote.
// The same sweep drives the real study runner (studies::run_study), whose progress reports are
// what `stickslip study run` and the server confirm.
//
// Default: every N up to 24, then a stride that gives about 40 values of N per kind and mode.
// STICKSLIP_FAULTS_LONG=1: every N.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <functional>
#include <map>
#include <optional>
#include <ostream>
#include <set>
#include <string>
#include <vector>

#include "faults/file_facts.h"
#include "stickslip/store/store.h"
#include "stickslip/studies/runner.h"
#include "stickslip/studies/spec.h"
#include "support/fault_vfs.h"
#include "support/temp_dir.h"

namespace stickslip {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using store::DiagnosisTrace;
using store::RunRecord;
using store::RunWriter;
using store::Store;
using store::StoreError;
using store::StudyState;
using testing::FaultKind;
using testing::FaultVfs;
using testing::RawDb;

constexpr int kRuns = 12;
constexpr std::size_t kBatch = 4;
const std::string kStudy = "st-faults0000000000001";
const std::string kStudyKey = "faults-study-key";
const std::string kDiagnosis = "dg-faults0000000000001";
const std::string kDiagnosisKey = "faults-diagnosis-key";
const std::string kResult = R"({"verdict":"viscous","gain":0.5})";

/// Run i of the workload: fixed content (finished_at too), so that files compare exactly. Every
/// third run has a trace; every fifth diverged.
RunRecord run_of(std::int64_t i) {
  RunRecord r;
  r.study_id = kStudy;
  r.design_index = i;
  r.params_json = R"({"model":"lugre","va_over_vd":)" + std::to_string(0.5 * i) + "}";
  r.param_hash = store::param_hash(r.params_json);
  r.model = "lugre";
  r.va_over_vd = 0.5 * static_cast<double>(i);
  r.status = i % 5 == 4 ? "diverged" : "ok";
  if (r.status != "ok") r.error = "step size underflow at t = 0.25 s";
  r.wall_time_s = 0.01 * static_cast<double>(i);
  r.t_end = 1.0;
  r.steps = 1000 + i;
  r.finished_at = "2026-11-25T12:00:00.000Z";
  for (int s = 1; s <= 2; ++s) {
    store::StageMetricsRecord m;
    m.stage = s;
    m.t_start = s - 1.0;
    m.t_end = s;
    m.amplitude = 0.1 * static_cast<double>(i) + s;
    m.amplitude_raw = m.amplitude * 1.01;
    m.mean_force = 2.5;
    m.mean_friction = 2.4;
    m.slip_events = 3 + i;
    m.mean_period = 0.02;
    r.stages.push_back(m);
  }
  if (i % 3 == 0)
    for (int k = 0; k < 200; ++k)  // 200 samples: a trace spans pages
      r.trace.push_back({0.005 * k, 1.0 + 1e-3 * k, 0.9, 1e-6 * k, 1e-3, 2e-6 * k});
  return r;
}

std::vector<DiagnosisTrace> diagnosis_traces() {
  std::vector<DiagnosisTrace> out(2);
  for (std::size_t r = 0; r < out.size(); ++r) {
    out[r].run = "run" + std::to_string(r);
    for (int k = 0; k < 300; ++k) {
      out[r].t.push_back(0.01 * k);
      out[r].measured.push_back(1.0 + 0.01 * k);
      out[r].base.push_back(1.0 + 0.011 * k);
      out[r].extended.push_back(1.0 + 0.0101 * k);
    }
  }
  return out;
}

store::NewStudy new_study() {
  store::NewStudy s;
  s.id = kStudy;
  s.name = "faults";
  s.spec_json = R"({"name":"faults"})";
  s.spec_hash = store::param_hash(s.spec_json);
  s.total_runs = kRuns;
  s.idempotency_key = kStudyKey;
  s.request_hash = s.spec_hash;
  return s;
}

store::NewDiagnosis new_diagnosis() {
  store::NewDiagnosis d;
  d.id = kDiagnosis;
  d.name = "faults-dataset";
  d.request_json = R"({"manifest":{"name":"faults-dataset"},"files":{}})";
  d.request_hash = store::param_hash(d.request_json);
  d.idempotency_key = kDiagnosisKey;
  return d;
}

/// What the workload's calls confirmed (returned without an error).
struct Confirmed {
  bool study = false;
  std::set<std::int64_t> runs;
  bool study_succeeded = false;
  bool diagnosis = false;
  bool diagnosis_succeeded = false;
  std::vector<std::string> errors;  ///< every StoreError seen
};

/// Calls f up to `tries` times until it does not throw StoreError; whether it succeeded.
bool attempt(const std::function<void()>& f, Confirmed& c, int tries = 2) {
  for (int t = 0; t < tries; ++t) {
    try {
      f();
      return true;
    } catch (const StoreError& e) {
      c.errors.push_back(e.what());
    }
  }
  return false;
}

/// The workload. A failed call is tried once more (as a client that retries would); a step
/// that still fails ends the workload. Everything is closed before it returns (the last close
/// checkpoints the WAL, under the same faults).
Confirmed workload(const fs::path& db) {
  Confirmed c;
  std::optional<Store> s;
  if (!attempt([&] { s.emplace(Store::open(db)); }, c)) return c;
  if (!attempt([&] { c.study = s->create_study(new_study()).study.id == kStudy; }, c)) return c;
  {
    std::optional<RunWriter> w;
    if (!attempt([&] { w.emplace(RunWriter::open(db, {.max_batch = kBatch, .max_delay = 1h})); },
                 c))
      return c;
    std::vector<std::int64_t> pending;
    const auto confirm_if_flushed = [&] {
      if (w->buffered() != 0) return;
      c.runs.insert(pending.begin(), pending.end());
      pending.clear();
    };
    for (std::int64_t i = 0; i < kRuns; ++i) {
      pending.push_back(i);
      try {
        w->add(run_of(i));
      } catch (const StoreError& e) {  // the batch stays buffered; the next add retries it
        c.errors.push_back(e.what());
      }
      confirm_if_flushed();
    }
    if (w->buffered() > 0) attempt([&] { w->flush(); }, c);
    confirm_if_flushed();
  }  // the writer's destructor may still commit what is buffered: present but not confirmed
  if (static_cast<int>(c.runs.size()) == kRuns)
    c.study_succeeded =
        attempt([&] { s->set_study_state(kStudy, StudyState::kSucceeded); }, c);
  if (!attempt([&] { c.diagnosis = s->create_diagnosis(new_diagnosis()).diagnosis.id == kDiagnosis; },
               c))
    return c;
  if (!attempt([&] { s->set_diagnosis_state(kDiagnosis, StudyState::kRunning); }, c)) return c;
  attempt([&] {
    c.diagnosis_succeeded = s->finish_diagnosis(kDiagnosis, StudyState::kSucceeded, kResult,
                                                std::nullopt, diagnosis_traces());
  }, c);
  return c;
}

/// After the fault: the workload's records are in the file (see the header comment).
void expect_confirmed_kept(const fs::path& db, const Confirmed& c,
                           const std::map<std::int64_t, std::string>& reference_runs) {
  if (!fs::exists(db)) {
    EXPECT_FALSE(c.study) << "the study was confirmed but the file is gone";
    return;
  }
  testing::expect_sound_file(db, "after the fault");
  RawDb raw(db);
  const bool has_schema =
      raw.integer("SELECT count(*) FROM sqlite_master WHERE name = 'studies'") > 0;
  if (!has_schema) {
    EXPECT_FALSE(c.study) << "the study was confirmed but the file has no schema";
    return;
  }
  const auto q = testing::quoted(kStudy);
  if (c.study) {
    EXPECT_EQ(raw.integer("SELECT count(*) FROM studies WHERE id = " + q), 1)
        << "the confirmed study is lost";
  }
  const auto stored = testing::stored_runs(raw, kStudy);
  for (const auto i : c.runs) EXPECT_TRUE(stored.count(i)) << "confirmed run " << i << " is lost";
  // Every stored run is whole and as written (confirmed or not).
  for (const auto& [i, content] : testing::run_contents(raw, kStudy, true))
    EXPECT_EQ(content, reference_runs.at(i)) << "run " << i << " differs from what was written";
  if (c.study_succeeded) {
    EXPECT_EQ(raw.text("SELECT state FROM studies WHERE id = " + q), "succeeded");
  }
  const auto dq = testing::quoted(kDiagnosis);
  if (c.diagnosis) {
    EXPECT_EQ(raw.integer("SELECT count(*) FROM diagnoses WHERE id = " + dq), 1)
        << "the confirmed diagnosis is lost";
  }
  if (c.diagnosis_succeeded) {
    EXPECT_EQ(raw.text("SELECT state || result_json FROM diagnoses WHERE id = " + dq),
              "succeeded" + kResult);
    EXPECT_EQ(raw.integer("SELECT count(*) FROM diagnosis_traces WHERE diagnosis_id = " + dq), 2);
  }
  // An outcome is stored with its traces or not at all.
  const std::string state = raw.text("SELECT state FROM diagnoses WHERE id = " + dq);
  EXPECT_EQ(raw.integer("SELECT count(*) FROM diagnosis_traces WHERE diagnosis_id = " + dq),
            state == "succeeded" ? 2 : 0) << "state " << state;
}

/// Runs the workload to its end on the same file (a restart), checking that nothing is written
/// twice.
void complete(const fs::path& db, const Confirmed& c) {
  auto s = Store::open(db);
  const auto created = s.create_study(new_study());
  EXPECT_EQ(created.study.id, kStudy);
  if (c.study) {
    EXPECT_FALSE(created.created) << "the confirmed study was created again";
  }
  const auto before = s.completed_design_indices(kStudy);
  {
    auto w = RunWriter::open(db, {.max_batch = 1000, .max_delay = 1h});
    for (std::int64_t i = 0; i < kRuns; ++i) w.add(run_of(i));
    const auto f = w.flush();
    EXPECT_EQ(f.duplicates, before.size());
    EXPECT_EQ(f.inserted + f.duplicates, static_cast<std::size_t>(kRuns));
  }
  s.set_study_state(kStudy, StudyState::kSucceeded);
  const auto d = s.create_diagnosis(new_diagnosis());
  if (c.diagnosis) {
    EXPECT_FALSE(d.created) << "the confirmed diagnosis was created again";
  }
  if (d.diagnosis.state != StudyState::kSucceeded) {
    s.set_diagnosis_state(kDiagnosis, StudyState::kRunning);
    EXPECT_TRUE(s.finish_diagnosis(kDiagnosis, StudyState::kSucceeded, kResult, std::nullopt,
                                   diagnosis_traces()));
  }
}

/// Everything a finished workload leaves in a file that must not depend on faults on the way.
std::string file_contents(const fs::path& db) {
  RawDb raw(db);
  std::string out;
  for (const auto& [i, content] : testing::run_contents(raw, kStudy, true))
    out += std::to_string(i) + " " + content + "\n";
  out += raw.text("SELECT id || name || state || total_runs || runs_done || runs_ok || "
                  "runs_failed || idempotency_key FROM studies");
  out += raw.text("SELECT count(*) FROM studies") + raw.text("SELECT count(*) FROM diagnoses");
  out += raw.text("SELECT id || name || state || result_json || idempotency_key FROM diagnoses");
  out += raw.text("SELECT group_concat(run_index || run || n_samples || hex(t) || hex(measured) "
                  "|| hex(base) || hex(extended), ';') FROM diagnosis_traces");
  return out;
}

/// 1..24, then a stride so that about 40 values cover 1..last; every value when long.
std::vector<long> values_of_n(long last) {
  std::vector<long> out;
  const long stride = testing::long_faults() ? 1 : std::max(1L, (last - 24) / 16);
  for (long n = 1; n <= last; n += n < 24 ? 1 : stride) out.push_back(n);
  if (out.back() != last) out.push_back(last);
  return out;
}

struct Case {
  FaultKind kind;
  bool persist;
  int code = 0;  ///< 0: the kind's I/O error (fault_vfs.h)
  const char* name = "";
};
std::string case_name(const ::testing::TestParamInfo<Case>& info) { return info.param.name; }
// GoogleTest prints a parameter in the test's CTest name: its name rather than its bytes.
void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

class StoreIoFaults : public ::testing::TestWithParam<Case> {
 protected:
  stickslip::testing::TempDir dir_{"stickslip-io-faults"};
};

TEST_P(StoreIoFaults, EveryConfirmedRecordIsKeptAndTheWorkloadCompletes) {
  const Case param = GetParam();
  // The reference: the workload without faults.
  const fs::path ref = dir_ / "reference.db";
  std::map<std::int64_t, std::string> reference_runs;
  std::string reference;
  FaultVfs vfs;
  {
    const Confirmed c = workload(ref);
    ASSERT_TRUE(c.errors.empty()) << c.errors.front();
    ASSERT_TRUE(c.diagnosis_succeeded && c.study_succeeded);
    reference_runs = testing::run_contents(RawDb(ref), kStudy, true);
    reference = file_contents(ref);
    ASSERT_EQ(reference_runs.size(), static_cast<std::size_t>(kRuns));
  }
  // How many calls of this kind the workload makes.
  vfs.reset_counts();
  workload(dir_ / "count.db");
  const long calls = vfs.calls(param.kind);
  ASSERT_GT(calls, 0);

  long cases = 0, injected = 0, failed_workloads = 0;
  for (const long n : values_of_n(calls + 1)) {
    const fs::path db = dir_ / ("n" + std::to_string(n) + ".db");
    SCOPED_TRACE(std::string(param.name) + ": " + to_string(param.kind) + " call " +
                 std::to_string(n) + (param.persist ? " and every later one" : "") + " fails");
    vfs.reset_counts();
    vfs.arm(param.kind, n, param.persist, param.code);
    const Confirmed c = workload(db);
    injected += vfs.injected(param.kind);
    vfs.disarm();
    ++cases;
    if (!c.errors.empty()) ++failed_workloads;
    expect_confirmed_kept(db, c, reference_runs);
    ASSERT_NO_THROW(complete(db, c)) << (c.errors.empty() ? "" : c.errors.back());
    EXPECT_EQ(file_contents(db), reference);
    testing::expect_sound_file(db, "after completing");
    if (HasFailure()) break;  // one broken N is enough to read
    for (const char* ext : {"", "-wal", "-shm", "-journal"}) fs::remove(db.string() + ext);
  }
  // The numbers of docs/store.md (Guarantees).
  std::printf("[faults] store %s: %ld %s calls per workload, %ld cases, %ld errors injected, "
              "%ld workloads saw an error\n",
              param.name, calls, to_string(param.kind), cases, injected, failed_workloads);
  RecordProperty("calls", std::to_string(calls));
  RecordProperty("cases", std::to_string(cases));
  RecordProperty("injected", std::to_string(injected));
  EXPECT_GT(failed_workloads, 0) << "no injected error reached the workload";
}

INSTANTIATE_TEST_SUITE_P(Sweep, StoreIoFaults,
                         ::testing::Values(
                             Case{FaultKind::kWrite, false, 0, "WriteNth"},
                             Case{FaultKind::kWrite, true, 0, "WriteFromNthOn"},
                             Case{FaultKind::kWrite, true, SQLITE_FULL, "DiskFullFromNthOn"},
                             Case{FaultKind::kSync, false, 0, "SyncNth"},
                             Case{FaultKind::kSync, true, 0, "SyncFromNthOn"},
                             Case{FaultKind::kLock, false, 0, "LockNth"},
                             Case{FaultKind::kLock, true, 0, "LockFromNthOn"},
                             Case{FaultKind::kLock, false, SQLITE_BUSY, "LockBusyNth"}),
                         case_name);

// ---------------------------------------------------------------------------------------------
// The study runner under the same faults: 8 runs, committed in batches of 2 (the runner's
// progress reports follow each commit: they are what `stickslip study run` prints and the server
// serves as progress.done).
// ---------------------------------------------------------------------------------------------

constexpr const char* kRunnerSpec = R"({"name": "faults-runner",
    "stages": [{"duration": 0.1}, {"duration": 0.1, "f": 1500}],
    "integrator": {"kind": "rk4", "dt": 1e-5},
    "design": {"type": "grid", "axes": [
      {"name": "model", "values": ["dahl", "lugre"]},
      {"name": "va_over_vd", "values": [0, 1, 2, 3]}]}})";

studies::RunnerOptions runner_options(std::int64_t* confirmed) {
  studies::RunnerOptions o;
  o.threads = 1;
  o.writer.max_batch = 2;
  o.writer.max_delay = 1h;
  o.on_progress = [confirmed](const studies::Progress& p) {
    *confirmed = std::max(*confirmed, p.done);
  };
  return o;
}

/// Creates the runner's study in a new store (without faults); its id.
std::string create_runner_study(const fs::path& db, const studies::StudySpec& spec) {
  auto s = Store::open(db);
  return studies::create_or_find_study(s, spec).id;
}

class RunnerIoFaults : public ::testing::TestWithParam<Case> {
 protected:
  stickslip::testing::TempDir dir_{"stickslip-runner-faults"};
};

TEST_P(RunnerIoFaults, EveryReportedRunIsKeptAndTheStudyCompletesOnRestart) {
  const Case param = GetParam();
  const auto parsed = studies::parse_study(kRunnerSpec);
  ASSERT_TRUE(parsed.ok()) << common::to_string(parsed.errors);
  const studies::StudySpec& spec = *parsed.spec;
  FaultVfs vfs;
  std::map<std::int64_t, std::string> reference;
  {
    const fs::path ref = dir_ / "reference.db";
    const std::string id = create_runner_study(ref, spec);
    std::int64_t confirmed = 0;
    const auto sum = studies::run_study(ref, id, spec, runner_options(&confirmed));
    ASSERT_EQ(sum.outcome, studies::RunOutcome::kCompleted) << sum.error;
    reference = testing::run_contents(RawDb(ref), id, false);
    ASSERT_EQ(reference.size(), spec.run_count());
  }
  long calls = 0;
  {
    const fs::path db = dir_ / "count.db";
    const std::string id = create_runner_study(db, spec);
    std::int64_t confirmed = 0;
    vfs.reset_counts();
    studies::run_study(db, id, spec, runner_options(&confirmed));
    calls = vfs.calls(param.kind);
  }
  ASSERT_GT(calls, 0);
  long cases = 0, injected = 0, failed_studies = 0;
  // Fewer values of N than the store sweep: a run of the runner costs more.
  const long stride = testing::long_faults() ? 1 : std::max(1L, calls / 12);
  for (long n = 1; n <= calls + 1; n += stride) {
    SCOPED_TRACE(std::string(param.name) + ": " + to_string(param.kind) + " call " +
                 std::to_string(n) + (param.persist ? " and every later one" : "") + " fails");
    const fs::path db = dir_ / ("n" + std::to_string(n) + ".db");
    const std::string id = create_runner_study(db, spec);
    std::int64_t confirmed = 0;
    vfs.reset_counts();
    vfs.arm(param.kind, n, param.persist, param.code);
    const auto sum = studies::run_study(db, id, spec, runner_options(&confirmed));
    injected += vfs.injected(param.kind);
    vfs.disarm();
    ++cases;
    if (sum.outcome != studies::RunOutcome::kCompleted) ++failed_studies;
    testing::expect_sound_file(db, "after the fault");
    {
      RawDb raw(db);
      const auto stored = testing::run_contents(raw, id, false);
      EXPECT_GE(static_cast<std::int64_t>(stored.size()), confirmed)
          << "the runner reported " << confirmed << " runs stored; the file holds "
          << stored.size();
      for (const auto& [i, content] : stored) EXPECT_EQ(content, reference.at(i)) << "run " << i;
      if (sum.outcome == studies::RunOutcome::kCompleted) {
        EXPECT_EQ(raw.text("SELECT state FROM studies WHERE id = " + testing::quoted(id)),
                  "succeeded");
      }
    }
    // The restart: the same call finishes the study, computing only what is missing.
    std::int64_t after = 0;
    const auto again = studies::run_study(db, id, spec, runner_options(&after));
    EXPECT_EQ(again.outcome, studies::RunOutcome::kCompleted) << again.error;
    EXPECT_EQ(again.skipped + again.computed, static_cast<std::int64_t>(spec.run_count()));
    EXPECT_EQ(testing::run_contents(RawDb(db), id, false), reference);
    EXPECT_EQ(RawDb(db).text("SELECT state FROM studies WHERE id = " + testing::quoted(id)),
              "succeeded");
    testing::expect_sound_file(db, "after the restart");
    if (HasFailure()) break;
    for (const char* ext : {"", "-wal", "-shm", "-journal"}) fs::remove(db.string() + ext);
  }
  std::printf("[faults] runner %s: %ld %s calls per study, %ld cases, %ld errors injected, "
              "%ld studies saw an error\n",
              param.name, calls, to_string(param.kind), cases, injected, failed_studies);
  RecordProperty("calls", std::to_string(calls));
  RecordProperty("cases", std::to_string(cases));
  RecordProperty("injected", std::to_string(injected));
  EXPECT_GT(failed_studies, 0) << "no injected error reached the runner";
}

INSTANTIATE_TEST_SUITE_P(Sweep, RunnerIoFaults,
                         ::testing::Values(
                             Case{FaultKind::kWrite, false, 0, "WriteNth"},
                             Case{FaultKind::kWrite, true, SQLITE_FULL, "DiskFullFromNthOn"},
                             Case{FaultKind::kSync, false, 0, "SyncNth"},
                             Case{FaultKind::kLock, false, 0, "LockNth"}),
                         case_name);

}  // namespace
}  // namespace stickslip
