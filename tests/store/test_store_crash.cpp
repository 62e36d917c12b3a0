// Tests of the store under concurrency and crashes: WAL readers and writers do not block each
// other; a real SIGKILL never loses a committed run nor leaves a partial one.
#include "stickslip/store/store.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "store_test_support.h"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using namespace stickslip::store::test_support;

// ---------------------------------------------------------------------------------------------
// Concurrency and crash safety
// ---------------------------------------------------------------------------------------------

TEST_F(StoreTest, WalReadersAndWriterDoNotBlockEachOther) {
  const std::string study = make_study(100);
  auto writer = RunWriter::open(db_, WriterOptions{.busy_timeout = 3000ms});
  for (int i = 0; i < 10; ++i) writer.add(simple_run(study, i));
  writer.flush();

  // Another connection holds an open write transaction with an uncommitted run.
  RawDb other_writer(db_);
  other_writer.exec("BEGIN IMMEDIATE");
  other_writer.exec("INSERT INTO runs (study_id, design_index, param_hash, params_json, status, "
                    "steps, finished_at) VALUES ('" + study + "', 50, 'h', '{}', 'ok', 0, 'now')");
  auto reader = Store::open(db_, Store::Mode::kReadOnly, 3000ms);
  auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(reader.count_runs(study).done, 10);  // the last committed snapshot
  EXPECT_EQ(reader.get_runs(study).size(), 10u);
  EXPECT_EQ(reader.completed_design_indices(study).size(), 10u);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 1000ms) << "reader waited for the writer";
  other_writer.exec("COMMIT");
  EXPECT_EQ(reader.count_runs(study).done, 11);

  // A reader in the middle of a read transaction does not block the writer's commit.
  RawDb long_reader(db_);
  long_reader.exec("BEGIN");
  EXPECT_EQ(long_reader.integer("SELECT count(*) FROM runs"), 11);
  for (int i = 10; i < 15; ++i) writer.add(simple_run(study, i));
  t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(writer.flush().inserted, 5u);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 1000ms) << "writer waited for the reader";
  EXPECT_EQ(long_reader.integer("SELECT count(*) FROM runs"), 11);  // its snapshot
  long_reader.exec("COMMIT");
  EXPECT_EQ(long_reader.integer("SELECT count(*) FROM runs"), 16);
}

constexpr std::size_t kCrashBatch = 40;

/// The child: writes runs forever in batches of kCrashBatch and reports the highest committed
/// design index on fd after every commit. Only async-safe exits; no gtest.
[[noreturn]] void crash_child(const fs::path& db, const std::string& study, int fd) {
  try {
    auto writer = RunWriter::open(db, WriterOptions{.max_batch = kCrashBatch, .max_delay = 1h});
    const auto deadline = std::chrono::steady_clock::now() + 15s;
    for (std::int64_t i = 0;; ++i) {
      writer.add(simple_run(study, i));
      if (writer.buffered() == 0 && write(fd, &i, sizeof i) != sizeof i) _exit(4);
      if (std::chrono::steady_clock::now() > deadline) _exit(3);
    }
  } catch (...) {
    _exit(2);
  }
}

/// Reads one committed index from the child; false at EOF.
bool read_report(int fd, std::int64_t& index) {
  std::size_t got = 0;
  auto* p = reinterpret_cast<char*>(&index);
  while (got < sizeof index) {
    const ssize_t n = read(fd, p + got, sizeof index - got);
    if (n == 0) return false;
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return false;
    got += static_cast<std::size_t>(n);
  }
  return true;
}

void verify_after_crash(const fs::path& db, const std::string& study, std::int64_t max_reported) {
  RawDb raw(db);
  EXPECT_EQ(raw.text("PRAGMA integrity_check"), "ok");
  EXPECT_TRUE(raw.rows("PRAGMA foreign_key_check").empty());
  const std::int64_t n = raw.integer("SELECT count(*) FROM runs");
  EXPECT_GE(n, max_reported + 1);
  EXPECT_EQ(n % static_cast<std::int64_t>(kCrashBatch), 0) << "a batch was committed in part";
  EXPECT_EQ(raw.integer("SELECT count(DISTINCT design_index) FROM runs"), n);
  EXPECT_EQ(raw.integer("SELECT max(design_index) FROM runs"), n - 1);
  EXPECT_EQ(raw.integer("SELECT count(*) FROM runs WHERE design_index <= " +
                        std::to_string(max_reported)),
            max_reported + 1);
  // No partial run: every run has its 3 stages (and its trace when due), nothing is orphaned.
  EXPECT_EQ(raw.integer("SELECT count(*) FROM runs AS r WHERE (SELECT count(*) FROM stage_metrics "
                        "AS m WHERE m.study_id = r.study_id AND m.design_index = r.design_index) "
                        "<> 3"),
            0);
  EXPECT_EQ(raw.integer("SELECT count(*) FROM stage_metrics AS m WHERE NOT EXISTS (SELECT 1 FROM "
                        "runs AS r WHERE r.study_id = m.study_id AND r.design_index = "
                        "m.design_index)"),
            0);
  EXPECT_EQ(raw.integer("SELECT count(*) FROM traces"), (n + 3) / 4);
  EXPECT_EQ(raw.integer("SELECT count(*) FROM traces AS t WHERE NOT EXISTS (SELECT 1 FROM runs "
                        "AS r WHERE r.study_id = t.study_id AND r.design_index = t.design_index)"),
            0);
  (void)study;
}

TEST_F(StoreTest, SigkillNeverLosesCommittedRunsNorLeavesPartialOnes) {
  std::mt19937_64 rng(2024);
  for (int rep = 0; rep < 5; ++rep) {
    SCOPED_TRACE("repetition " + std::to_string(rep));
    const fs::path db = dir_ / ("crash-" + std::to_string(rep) + ".db");
    const std::string study = make_study(1'000'000, db);  // closed again before fork

    int fds[2];
    ASSERT_EQ(pipe(fds), 0);
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      close(fds[0]);
      crash_child(db, study, fds[1]);
    }
    close(fds[1]);
    std::int64_t max_reported = -1, index = 0;
    const int wanted = 1 + rep % 3;
    for (int k = 0; k < wanted; ++k) {
      if (!read_report(fds[0], index)) break;
      max_reported = index;
    }
    // Kill at an arbitrary moment: during an add, inside a commit, or between batches.
    std::this_thread::sleep_for(std::chrono::microseconds(rng() % 3000));
    kill(pid, SIGKILL);
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    while (read_report(fds[0], index)) max_reported = index;  // reports sent before death
    close(fds[0]);
    ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL)
        << "child exited early with status " << (WIFEXITED(status) ? WEXITSTATUS(status) : -1);
    ASSERT_GE(max_reported, static_cast<std::int64_t>(kCrashBatch) - 1) << "no commit reported";

    verify_after_crash(db, study, max_reported);

    // Resume: the store opens, reports what is done, and re-adding never duplicates.
    auto store = Store::open(db);
    const auto done = store.completed_design_indices(study);
    const auto n = static_cast<std::int64_t>(done.size());
    for (std::int64_t i = 0; i < n; ++i) ASSERT_EQ(done[static_cast<std::size_t>(i)], i);
    auto writer = RunWriter::open(db, WriterOptions{.max_batch = 100000});
    for (std::int64_t i = 0; i < n + 7; ++i) writer.add(simple_run(study, i));
    const FlushResult f = writer.flush();
    EXPECT_EQ(f.duplicates, static_cast<std::size_t>(n));
    EXPECT_EQ(f.inserted, 7u);
    EXPECT_EQ(store.count_runs(study).done, n + 7);
  }
}

}  // namespace
