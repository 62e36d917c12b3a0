// Other clients of a live store: while a real stickslipd runs a study and a diagnosis,
//  - the sqlite3 shell reads (it opens read-write by default), reads with -readonly, and writes a
//    row of its own; raw SQLite connections of another process open, read and close the file
//    (the pattern of issue 18's data loss); the read-only CLI commands read it;
//  - an external write lock is held for less than the busy timeout;
//  - a second stickslipd is started on the same file, and `stickslip study run` writes another
//    study into it.
// Each case then kills the server with kill -9 and checks the file against what the API and the
// CLI confirmed (every confirmed run and job is there, integrity_check ok, no duplicates); then a
// restart completes every job. The cases after the first run the study alone by default (their
// subject is the study's writes); STICKSLIP_FAULTS_LONG=1 adds the diagnosis to each.
//
// The store's single-writer lock (store/writer_lock.h) and the retries of a busy store (issue 18
// defect 3) are checked at the end: a lock held past the busy timeout, a second writer refused.
#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <thread>

#include "faults/live.h"
#include "support/temp_dir.h"

namespace stickslip {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using server::testing::CommandResult;
using server::testing::kClientBin;
using server::testing::kServerBin;
using server::testing::Process;
using server::testing::run_command;
using testing::Daemon;
using testing::Job;
using testing::RawDb;

bool have_sqlite3_shell() { return std::system("command -v sqlite3 >/dev/null 2>&1") == 0; }

class OtherClients : public ::testing::Test {
 protected:
  fs::path write(const std::string& name, const std::string& text) {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p;
  }
  /// A study (80 runs of 2 x 1 s) and the small diagnosis, submitted to d. The diagnosis (about
  /// 15 s of fitting) is left out of the cases whose subject is the study's writes unless
  /// STICKSLIP_FAULTS_LONG=1 (diagnosis = false).
  std::vector<Job> submit_jobs(Daemon& d, const std::string& tag, bool diagnosis = true) {
    std::vector<Job> jobs;
    jobs.push_back(testing::make_job("studies", tag + "-study",
                                     write(tag + "-study.json", testing::study_json(tag, 40, 1.0))));
    if (diagnosis || testing::long_faults())
      jobs.push_back(testing::make_job(
          "diagnoses", tag + "-diagnosis",
          write(tag + "-diagnosis.json", testing::diagnosis_body(dir_ / tag))));
    for (Job& job : jobs) testing::post_job(dir_.path(), d.url(), job);
    return jobs;
  }
  void poll(Daemon& d, std::vector<Job>& jobs) {
    for (Job& job : jobs) testing::poll_job(dir_.path(), d.url(), job);
  }
  /// Kills d (-9), checks the file against jobs, restarts, waits until every job succeeded,
  /// checks again and stops the server.
  void kill_check_and_finish(Daemon& d, std::vector<Job>& jobs, const std::vector<std::string>& opts) {
    poll(d, jobs);
    d.process().signal(SIGKILL);
    ASSERT_EQ(d.process().wait(20s), 128 + SIGKILL);
    testing::expect_jobs_kept(db(), jobs, "after the kill");
    Daemon again(dir_.path(), opts);
    ASSERT_TRUE(testing::wait_all_succeeded(dir_.path(), again.url(), jobs, 600s))
        << "not every job finished after the restart";
    again.process().signal(SIGTERM);
    EXPECT_EQ(again.process().wait(60s), 0);
    testing::expect_jobs_kept(db(), jobs, "at the end");
  }
  fs::path db() const { return dir_ / "e2e.db"; }

  const std::vector<std::string> opts_ = {"--diagnosis-threads", "1", "--diagnosis-grace", "0"};
  stickslip::testing::TempDir dir_{"stickslip-other-clients"};
};

/// Opens the file read-write with a plain SQLite connection of this process, reads and closes
/// it: the sequence that made another process' connection delete the live WAL (issue 18).
std::int64_t raw_read_write_count(const fs::path& db) {
  sqlite3* h = nullptr;
  std::int64_t n = -1;
  if (sqlite3_open_v2(db.c_str(), &h, SQLITE_OPEN_READWRITE, nullptr) == SQLITE_OK) {
    sqlite3_busy_timeout(h, 5000);
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(h, "SELECT count(*) FROM runs", -1, &st, nullptr) == SQLITE_OK &&
        sqlite3_step(st) == SQLITE_ROW)
      n = sqlite3_column_int64(st, 0);
    sqlite3_finalize(st);
  }
  sqlite3_close_v2(h);
  return n;
}

TEST_F(OtherClients, ShellRawConnectionsAndReadOnlyCliWhileTheServerWorksLoseNothing) {
  if (!have_sqlite3_shell()) GTEST_SKIP() << "no sqlite3 shell";
  Daemon d(dir_.path(), opts_);
  std::vector<Job> jobs = submit_jobs(d, "clients");
  const std::string dbs = db().string();
  int rounds = 0;
  for (; rounds < 6; ++rounds) {
    std::this_thread::sleep_for(300ms);
    poll(d, jobs);
    const CommandResult rw = run_command({"sqlite3", dbs, "SELECT count(*) FROM runs"}, dir_.path());
    EXPECT_EQ(rw.code, 0) << rw.err;
    const CommandResult ro =
        run_command({"sqlite3", "-readonly", dbs, "SELECT count(*) FROM runs"}, dir_.path());
    EXPECT_EQ(ro.code, 0) << ro.err;
    const CommandResult wr = run_command(
        {"sqlite3", "-cmd", ".timeout 5000", dbs,
         "INSERT OR REPLACE INTO meta (key, value) VALUES ('external-probe', '" +
             std::to_string(rounds) + "')"},
        dir_.path());
    EXPECT_EQ(wr.code, 0) << wr.err;
    for (int k = 0; k < 5; ++k) EXPECT_GE(raw_read_write_count(db()), 0);
    const CommandResult list = run_command({kClientBin, "study", "list", "--db", dbs}, dir_.path());
    EXPECT_EQ(list.code, 0) << list.err;
    const CommandResult show =
        run_command({kClientBin, "study", "show", jobs[0].id, "--db", dbs}, dir_.path());
    EXPECT_EQ(show.code, 0) << show.err;
    poll(d, jobs);
  }
  // The WAL the server writes to is still the file's (issue 18: it was deleted by another
  // client's close, and later commits went to an unlinked file).
  EXPECT_TRUE(fs::exists(dbs + "-wal"));
  testing::expect_jobs_kept(db(), jobs, "while the server runs");
  kill_check_and_finish(d, jobs, opts_);
  EXPECT_EQ(RawDb(db()).text("SELECT value FROM meta WHERE key = 'external-probe'"),
            std::to_string(rounds - 1));
}

TEST_F(OtherClients, ExternalWriteLockShorterThanTheBusyTimeoutDelaysButNeverFailsAJob) {
  if (!have_sqlite3_shell()) GTEST_SKIP() << "no sqlite3 shell";
  Daemon d(dir_.path(), opts_);
  std::vector<Job> jobs = submit_jobs(d, "short-lock", false);
  for (int k = 0; k < 2; ++k) {
    std::this_thread::sleep_for(500ms);
    // The shell holds the write lock for 2 s (the busy timeout is 5 s).
    const CommandResult lock = run_command(
        {"sqlite3", "-cmd", ".timeout 5000", db().string(),
         "BEGIN IMMEDIATE; INSERT OR REPLACE INTO meta (key, value) VALUES ('lock', 'held');",
         ".shell sleep 2", "COMMIT;"},
        dir_.path());
    EXPECT_EQ(lock.code, 0) << lock.err;
    poll(d, jobs);
  }
  for (const Job& job : jobs) {
    const testing::Curl c = testing::curl(dir_.path(), {d.url() + "/v1/" + job.collection + "/" + job.id});
    EXPECT_EQ(nlohmann::json::parse(c.body)["state"].get<std::string>().find("fail"),
              std::string::npos)
        << c.body.substr(0, 400);
  }
  ASSERT_TRUE(testing::wait_all_succeeded(dir_.path(), d.url(), jobs, 600s));
  kill_check_and_finish(d, jobs, opts_);
}

TEST_F(OtherClients, SecondServerAndStudyRunOnTheSameStoreLoseNothing) {
  Daemon first(dir_.path(), opts_);
  std::vector<Job> jobs = submit_jobs(first, "second", false);
  std::this_thread::sleep_for(500ms);
  poll(first, jobs);
  // A second server on the same file (it may refuse: the store has one writer).
  const fs::path port2 = dir_ / "port2";
  Process second({kServerBin, "--db", db().string(), "--port", "0", "--port-file",
                  port2.string(), "--threads", "1", "--diagnosis-threads", "1"},
                 (dir_ / "second").string());
  // `stickslip study run` of another study into the same file (it may refuse too).
  const fs::path other = write("other.json", testing::study_json("other", 10, 0.5));
  Process cli({kClientBin, "study", "run", other.string(), "--db", db().string(), "--threads", "1"},
              (dir_ / "cli").string());
  for (int k = 0; k < 8; ++k) {
    std::this_thread::sleep_for(250ms);
    poll(first, jobs);
  }
  const auto cli_code = cli.wait(300s);
  ASSERT_TRUE(cli_code.has_value());
  const std::string cli_err = cli.err();
  const bool cli_ran = *cli_code == 0;
  if (!cli_ran) {
    // Refused: it must say why, naming the server that holds the store.
    EXPECT_NE(cli_err.find(std::to_string(first.process().pid())), std::string::npos) << cli_err;
  }
  second.signal(SIGKILL);
  second.wait(20s);
  testing::expect_jobs_kept(db(), jobs, "with the second server and the CLI");
  if (cli_ran) {
    RawDb raw(db());
    EXPECT_EQ(raw.integer("SELECT count(*) FROM studies WHERE name = 'other' AND state = "
                          "'succeeded'"),
              1);
    EXPECT_EQ(raw.integer("SELECT count(*) FROM runs AS r JOIN studies AS s ON r.study_id = s.id "
                          "WHERE s.name = 'other'"),
              20);
  }
  kill_check_and_finish(first, jobs, opts_);
  std::printf("[faults] second server: %s; study run: %s\n",
              second.err().find("error") != std::string::npos ? "refused" : "started",
              cli_ran ? "ran" : "refused");
}

// ---------------------------------------------------------------------------------------------
// One writer per store and a busy store (issue 18: item 1, defect 3).
// ---------------------------------------------------------------------------------------------

TEST_F(OtherClients, ExternalWriteLockLongerThanTheBusyTimeoutNeverFailsAJob) {
  if (!have_sqlite3_shell()) GTEST_SKIP() << "no sqlite3 shell";
  Daemon d(dir_.path(), opts_);
  std::vector<Job> jobs = submit_jobs(d, "long-lock", false);
  std::this_thread::sleep_for(500ms);
  poll(d, jobs);
  const CommandResult lock = run_command(
      {"sqlite3", "-cmd", ".timeout 5000", db().string(),
       "BEGIN IMMEDIATE; INSERT OR REPLACE INTO meta (key, value) VALUES ('lock', 'held');",
       ".shell sleep 8", "COMMIT;"},
      dir_.path());
  EXPECT_EQ(lock.code, 0) << lock.err;
  ASSERT_TRUE(testing::wait_all_succeeded(dir_.path(), d.url(), jobs, 600s))
      << "a job did not succeed after an 8 s external lock";
  kill_check_and_finish(d, jobs, opts_);
}

TEST_F(OtherClients, SecondWriterIsRefusedNamingTheServerThatHoldsTheStore) {
  Daemon first(dir_.path(), opts_);
  std::vector<Job> jobs = submit_jobs(first, "refused", false);
  const std::string pid = std::to_string(first.process().pid());
  const CommandResult second = run_command(
      {kServerBin, "--db", db().string(), "--port", "0", "--threads", "1"}, dir_.path(), {}, 30s);
  EXPECT_NE(second.code, 0) << "a second server started on a store another server holds";
  EXPECT_NE(second.err.find(pid), std::string::npos) << second.err;
  const fs::path other = write("other.json", testing::study_json("other", 4, 0.2));
  const CommandResult cli = run_command(
      {kClientBin, "study", "run", other.string(), "--db", db().string()}, dir_.path(), {}, 60s);
  EXPECT_NE(cli.code, 0) << "study run wrote into a store a server holds";
  EXPECT_NE(cli.err.find(pid), std::string::npos) << cli.err;
  kill_check_and_finish(first, jobs, opts_);
}

}  // namespace
}  // namespace stickslip
