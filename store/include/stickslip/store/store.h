#pragma once
// The SQLite store for studies and their runs (schema and example queries: docs/store.md).
//
// A study is a JSON spec expanded into total_runs design points; a run is identified by
// (study_id, design_index). Runs are written only through a RunWriter, which buffers finished
// runs and commits them in batches, one transaction per batch: a run is stored with all its
// stage metrics and its trace, or not at all, even if the process is killed mid-commit.
//
// Threading contract (never share a connection across threads):
//  - Every Store and every RunWriter owns its own sqlite3 connection. Neither is thread-safe:
//    use each object from one thread at a time (moving it to another thread is fine).
//  - One RunWriter per database and process, driven by one thread (e.g. the thread that collects
//    results from the OpenMP workers). It has no thread of its own: its time-based commit
//    happens inside add() and flush_if_due(), so call flush_if_due() when idle.
//  - Readers (server handlers, resume logic) open their own Store, read-only or read-write.
//    With WAL, readers see the last committed snapshot and never block the writer, and the
//    writer never blocks readers. Concurrent writers (a Store changing a study's state and the
//    RunWriter) serialise on SQLite's write lock; each waits up to busy_timeout.
//
// One writer (writer_lock.h): every read-write open takes the store's writer lock for this
// process, so a second process that opens the store read-write fails with StoreLockedError
// naming the holder. The first read-write open of a process runs a bounded PRAGMA quick_check
// before anything is written and refuses a damaged file.
//
// Durability: journal_mode=WAL with synchronous=NORMAL. A commit is appended to the WAL without
// an fsync (the WAL is synced at checkpoints), so a killed process loses nothing it committed
// (the data is in the OS page cache); a power loss may roll back the last few commits but never
// corrupts the database. Lost runs are simply recomputed on resume (completed_design_indices).
//
// Every failure is a StoreError whose message names the database path, what was being done and,
// for SQLite errors, SQLite's message and extended result code.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace stickslip::store {

/// What kind of failure of the store a StoreError is.
enum class StoreFault {
  kNone,        ///< not a fault of the store: a bad record, an unknown id, a foreign file, ...
  kBusy,        ///< another connection held the write lock past the busy timeout: try again
  kPersistent,  ///< I/O error, disk full, corruption, a vanished or unwritable file
};

class StoreError : public std::runtime_error {
 public:
  /// sqlite_code: SQLite's extended result code when SQLite failed, else 0.
  explicit StoreError(const std::string& what, int sqlite_code = 0)
      : std::runtime_error(what), code_(sqlite_code) {}
  int sqlite_code() const noexcept { return code_; }
  /// kBusy for SQLITE_BUSY and SQLITE_LOCKED; kPersistent for SQLITE_IOERR, SQLITE_CORRUPT,
  /// SQLITE_FULL, SQLITE_CANTOPEN, SQLITE_NOTADB, SQLITE_READONLY, SQLITE_PROTOCOL and
  /// SQLITE_NOMEM; kNone otherwise.
  StoreFault fault() const noexcept;

 private:
  int code_ = 0;
};

/// PRAGMA application_id of a stickslip database: "SSLP" = 0x53534C50.
inline constexpr std::int32_t kStoreApplicationId = 0x53534C50;
/// meta.schema_version written by this build. Version 2 added the diagnoses table, version 3 the
/// run counters of each study (kept by triggers; v_study_progress reads them), version 4 the
/// diagnosis_traces table (a diagnosis' measured, base and extended series). An older database
/// is migrated step by step on its first read-write open (nothing in it changes but the added
/// tables, columns, triggers and meta rows), and read as it is by a read-only open.
/// Version 5 keeps every job (studies, diagnoses, ...) in one jobs table; studies, diagnoses and
/// v_study_progress became views over it (docs/store.md).
inline constexpr int kStoreSchemaVersion = 5;

/// 64-bit FNV-1a of the bytes of canonical_json as 16 lowercase hex digits.
/// Hand-written on purpose: SQLite has no hash function, and a parameter fingerprint needs no
/// cryptographic strength, only a fixed, documented, dependency-free definition (offset basis
/// 0xcbf29ce484222325, prime 0x100000001b3) that Python can reproduce in three lines.
std::string param_hash(std::string_view canonical_json);

/// A new job id: prefix + "-" + 12 hex digits of the UTC time in ms + 8 hex digits. The ids made
/// by one process sort in the order they were made, also within one millisecond (the low digits
/// are random but kept above the last id's), so id order is creation order.
std::string new_job_id(const std::string& prefix);
/// A new, short, unique study id "st-" + 12 hex digits of the UTC time in ms + 8 random hex
/// digits, e.g. "st-018f3a2b4c5d9e8f7a6b". Ids made by it sort in creation order.
std::string new_study_id();
/// The same for diagnoses: "dg-" + 12 hex digits of the UTC time in ms + 8 random hex digits.
std::string new_diagnosis_id();

/// Current UTC time as ISO-8601 with milliseconds, e.g. "2024-05-01T12:34:56.789Z".
std::string utc_now_iso8601();

enum class StudyState { kQueued, kRunning, kSucceeded, kFailed, kCancelled };
/// "queued", "running", "succeeded", "failed", "cancelled".
const char* to_string(StudyState s) noexcept;
/// Inverse of to_string; nullopt for anything else.
std::optional<StudyState> parse_study_state(std::string_view s) noexcept;

/// Input of Store::create_study.
struct NewStudy {
  std::string id;  ///< empty: new_study_id() is used
  std::string name;
  std::string spec_json;  ///< must be valid JSON
  std::string spec_hash;
  std::int64_t total_runs = 0;
  std::optional<std::string> idempotency_key;  ///< unique over all studies when set
  std::optional<std::string> request_hash;     ///< to tell a replay from a key reused by mistake
};

/// One row of the studies table.
struct StudyRecord {
  std::string id, name, spec_json, spec_hash;
  StudyState state = StudyState::kQueued;
  std::int64_t total_runs = 0;
  std::string created_at;                  ///< ISO-8601 UTC
  std::optional<std::string> started_at;   ///< set on the first switch to running
  std::optional<std::string> finished_at;  ///< set on a switch to succeeded/failed/cancelled
  std::optional<std::string> error;
  std::optional<std::string> idempotency_key, request_hash;
};

/// Input of Store::create_diagnosis.
struct NewDiagnosis {
  std::string id;  ///< empty: new_diagnosis_id() is used
  std::string name;          ///< the dataset's name
  std::string request_json;  ///< the whole request {"manifest", "files", "options"}; an object
  std::string request_hash;  ///< param_hash of the canonical request
  std::optional<std::string> idempotency_key;  ///< unique over all diagnoses when set
};

/// One row of the diagnoses table (request_json is read separately: it holds the CSVs).
struct DiagnosisRecord {
  std::string id, name, request_hash;
  StudyState state = StudyState::kQueued;  ///< the same five states as a study
  std::string created_at;
  std::optional<std::string> started_at, finished_at, error;
  std::optional<std::string> result_json;  ///< diagnosis.json (diagnosis::to_json) once succeeded
  std::optional<std::string> idempotency_key;
};

/// A diagnosis' series of one run at the decimated sample times of the fit (studies::RunSeries):
/// what `stickslip diagnose` plots in runK.png (schema version 4).
struct DiagnosisTrace {
  std::string run;                ///< the run's name in the manifest
  std::vector<double> t;          ///< [s]
  std::vector<double> measured;   ///< [N]
  std::vector<double> base;       ///< the calibrated base model + offset [N]
  std::vector<double> extended;   ///< the extended model + offset [N]; empty when there is none
};

/// What Store::list_diagnosis_traces says of one stored trace (without its samples).
struct DiagnosisTraceInfo {
  std::int64_t run_index = 0;  ///< position of the run in the manifest, from 0
  std::string run;
  std::int64_t samples = 0;
  double t_first = 0, t_last = 0;  ///< [s]; NaN without samples
  bool has_extended = false;
};

struct CreatedDiagnosis {
  DiagnosisRecord diagnosis;
  bool created = false;  ///< false: the idempotency key was already stored; this is that row
};

/// A job of any kind (schema version 4, the jobs table). Studies and diagnoses are the kinds
/// "study" and "diagnosis"; StudyRecord and DiagnosisRecord are views of a JobRecord.
struct JobProgress {
  std::int64_t total = 0;   ///< units of work (a study: its runs)
  std::int64_t done = 0;    ///< units stored (a study: runs stored, kept by triggers on runs)
  std::int64_t failed = 0;  ///< of them failed (a study: runs that are not "ok")
};

/// Input of Store::create_job.
struct NewJob {
  std::string id;            ///< empty: new_job_id with the kind's prefix ("st", "dg", ...)
  std::string kind;          ///< "study", "diagnosis", ...
  std::string name;
  std::string request_json;  ///< what the job is asked to do; must be JSON
  std::string request_hash;  ///< empty: param_hash(request_json)
  std::int64_t progress_total = 0;
  std::optional<std::string> idempotency_key;   ///< unique per kind when set
  std::optional<std::string> idempotency_hash;  ///< hash of the request that carried the key
};

struct JobRecord {
  std::string id, kind, name, request_hash;
  StudyState state = StudyState::kQueued;
  JobProgress progress;
  std::string created_at;
  std::optional<std::string> started_at, finished_at, error;
  std::optional<std::string> idempotency_key, idempotency_hash;
  std::optional<std::string> request_json;  ///< read only when JobColumns::request
  std::optional<std::string> result_json;   ///< read only when JobColumns::result
};

/// The large columns a read includes (a diagnosis's request holds whole CSV files).
struct JobColumns {
  bool request = false;
  bool result = false;
};

struct CreatedJob {
  JobRecord job;
  bool created = false;  ///< false: the idempotency key was already stored; job is that row
};

struct CreatedStudy {
  StudyRecord study;  ///< the stored row
  bool created = false;  ///< false: the idempotency key was already stored; study is that row
};

/// Metrics of one stage (see stickslip/engine/simulate.h for their definitions). A NaN is
/// stored as NULL and read back as a quiet NaN; -0.0 reads back as +0.0 (SQLite stores integral
/// REAL values as integers); every other double, including +-inf, round-trips bit for bit.
struct StageMetricsRecord {
  int stage = 0;               ///< 1-based; 0 = its position in RunRecord::stages + 1
  double t_start = 0.0;        ///< [s]
  double t_end = 0.0;          ///< [s]
  double amplitude = 0.0;      ///< [N]
  double amplitude_raw = 0.0;  ///< [N]
  double mean_force = 0.0;     ///< [N]
  double mean_friction = 0.0;  ///< [N]
  std::int64_t slip_events = 0;
  double mean_period = 0.0;           ///< [s]
  std::optional<double> rmse;         ///< [N] against measured data of this stage; NULL if none
};

/// One decimated trace sample (SI): t [s], F_d [N], F_f [N], x [m], v [m/s], s [m].
struct TracePoint {
  double t = 0.0, F_d = 0.0, F_f = 0.0, x = 0.0, v = 0.0, s = 0.0;
};

/// Run statuses accepted by the store: "ok", "diverged", "invalid".
bool is_valid_run_status(std::string_view status) noexcept;

struct RunRecord {
  std::string study_id;
  std::int64_t design_index = 0;  ///< >= 0
  std::string param_hash;         ///< e.g. param_hash(canonical params JSON)
  std::string params_json;        ///< JSON object: name -> number, plus "model"
  std::optional<std::string> model;        ///< own indexed column; NULL if not applicable
  std::optional<double> va_over_vd;        ///< own indexed column; NULL if not applicable
  std::string status = "ok";               ///< "ok", "diverged" or "invalid"
  std::string error;                       ///< reason of a failure; stored as NULL when empty
  double wall_time_s = 0.0;
  double t_end = 0.0;                      ///< simulated time reached [s]
  std::int64_t steps = 0;
  std::vector<StageMetricsRecord> stages;  ///< completed stages only (may be empty)
  std::optional<double> rmse;              ///< [N] whole-trace rmse against measured data
  std::vector<TracePoint> trace;           ///< empty: no trace stored. Readers leave it empty;
                                           ///< use Store::get_trace.
  std::string finished_at;                 ///< ISO-8601 UTC; empty: RunWriter::add sets now
};

struct RunCounts {
  std::int64_t total = 0;   ///< studies.total_runs
  std::int64_t done = 0;    ///< runs stored, any status
  std::int64_t ok = 0;      ///< status "ok"
  std::int64_t failed = 0;  ///< status "diverged" or "invalid"
};

/// A study's view of its job record (job.kind must be "study"; job.request_json read).
StudyRecord study_from_job(const JobRecord& job);
RunCounts run_counts_of(const JobRecord& job);
/// A diagnosis's view of its job record.
DiagnosisRecord diagnosis_from_job(const JobRecord& job);

/// The result of a full check of a store file (check_store).
struct StoreCheck {
  std::vector<std::string> problems;  ///< empty: PRAGMA integrity_check said ok
  std::int64_t foreign_key_violations = 0;
  bool ok() const noexcept { return problems.empty() && foreign_key_violations == 0; }
};
/// PRAGMA integrity_check (every page and index; up to 100 problems) and foreign_key_check of a
/// stickslip database, on a read-only connection: safe while a server writes to it.
StoreCheck check_store(const std::filesystem::path& path);
/// How long the start-up PRAGMA quick_check may take before it is stopped (docs/store.md).
inline constexpr std::chrono::milliseconds kQuickCheckBudget{10000};

class Store {
 public:
  enum class Mode {
    kReadWriteCreate,  ///< create the file if missing; initialise an empty file
    kReadOnly,         ///< the file must exist and be an initialised stickslip database
  };
  static constexpr std::chrono::milliseconds kDefaultBusyTimeout{5000};

  /// Opens (and in kReadWriteCreate mode creates or initialises) a stickslip database.
  /// Throws StoreError naming the path when the file cannot be opened or created (missing
  /// directory, not writable), or is not a stickslip database: a non-SQLite file, an SQLite
  /// database of another application (application_id differs, or id 0 with tables in it), or
  /// another schema_version. A rejected file is never modified.
  static Store open(const std::filesystem::path& path, Mode mode = Mode::kReadWriteCreate,
                    std::chrono::milliseconds busy_timeout = kDefaultBusyTimeout);

  Store(Store&&) noexcept;
  Store& operator=(Store&&) noexcept;
  Store(const Store&) = delete;
  Store& operator=(const Store&) = delete;
  ~Store();

  const std::filesystem::path& path() const noexcept;

  // --- jobs (any kind; schema version 4) ---
  /// Inserts a job in state queued (created_at = now). Atomic with respect to the idempotency
  /// key: when (kind, idempotency_key) is already stored, nothing is inserted and the stored
  /// row is returned (with both large columns) with created == false. Throws StoreError when
  /// the id exists or request_json is not JSON.
  CreatedJob create_job(const NewJob& job);
  /// The job with this id (any kind), nullopt when there is none.
  std::optional<JobRecord> get_job(const std::string& id, JobColumns columns = {});
  std::optional<JobRecord> find_job_by_idempotency_key(const std::string& kind,
                                                       const std::string& key,
                                                       JobColumns columns = {});
  /// Keyset pagination of one kind in id (= creation) order: up to page_size jobs with
  /// id > after_id.
  /// With name_contains, only the jobs whose name contains it (ASCII case-insensitive).
  std::vector<JobRecord> list_jobs(const std::string& kind, std::size_t page_size,
                                   const std::string& after_id = "", JobColumns columns = {},
                                   const std::string& name_contains = "");
  /// The claim query: ids of the oldest jobs of kind that are queued or running, in id order, at
  /// most limit; one range of the partial index jobs_pending, whatever the number of jobs.
  std::vector<std::string> pending_jobs(const std::string& kind, std::size_t limit);
  /// queued or running -> running (started_at set if unset, error cleared); false when the job
  /// is no longer queued or running.
  bool claim_job(const std::string& id);
  /// The state rule of set_study_state, for a job of any kind.
  void set_job_state(const std::string& id, StudyState state,
                     const std::optional<std::string>& error = std::nullopt);
  /// Stores the outcome (succeeded with result_json, failed with error, or cancelled) in one
  /// statement, but only while the job is queued or running: false, changing nothing, when it
  /// was cancelled or finished meanwhile.
  bool finish_job(const std::string& id, StudyState state,
                  const std::optional<std::string>& result_json,
                  const std::optional<std::string>& error = std::nullopt);
  /// queued or running -> queued with this error (nullopt: none); false otherwise.
  bool requeue_job(const std::string& id, const std::optional<std::string>& error = std::nullopt);

  // --- studies (jobs of kind "study") ---
  /// Inserts a study in state queued (created_at = now). Atomic with respect to the
  /// idempotency key: when new_study.idempotency_key is already stored, nothing is inserted
  /// and the stored row is returned with created == false (compare request_hash to tell a
  /// replay from a conflict). Throws StoreError when the id exists or spec_json is not JSON.
  CreatedStudy create_study(const NewStudy& new_study);
  std::optional<StudyRecord> get_study(const std::string& id);
  /// Keyset pagination in id order (= creation order for new_study_id() ids): up to page_size
  /// studies with id > after_id (all ids when after_id is empty). With name_contains, only the
  /// studies whose name contains it (ASCII case-insensitive; the same keyset pages).
  std::vector<StudyRecord> list_studies(std::size_t page_size, const std::string& after_id = "",
                                        const std::string& name_contains = "");
  /// Sets state and error (nullopt: NULL). Running sets started_at if unset; a terminal state
  /// (succeeded, failed, cancelled) sets finished_at to now, any other state clears it.
  /// Throws StoreError for an unknown id.
  void set_study_state(const std::string& id, StudyState state,
                       const std::optional<std::string>& error = std::nullopt);
  /// Grows a study to total_runs runs (a Sobol design with "until" that doubled its base
  /// sample: the runs stored so far keep their design indices). Throws StoreError for an unknown
  /// id or a total smaller than the current one.
  void extend_study(const std::string& id, std::int64_t total_runs);
  std::optional<StudyRecord> find_by_idempotency_key(const std::string& key);
  /// The newest study of this name (ids sort in creation order), if any.
  std::optional<StudyRecord> find_newest_by_name(const std::string& name);
  /// The newest study with this name and spec_hash that is not cancelled (create-or-resume).
  std::optional<StudyRecord> find_resumable(const std::string& name, const std::string& spec_hash);

  // --- runs (read side; writes go through RunWriter) ---
  /// Ascending design indices of the stored runs of a study, whatever their status: on resume
  /// the runner computes only the indices missing here.
  std::vector<std::int64_t> completed_design_indices(const std::string& study_id);
  /// Keyset pagination: up to limit runs with design_index > after_index, ascending, each with
  /// its stage metrics (trace left empty).
  std::vector<RunRecord> get_runs(const std::string& study_id, std::int64_t after_index = -1,
                                  std::size_t limit = 1000);
  /// Throws StoreError for an unknown study.
  RunCounts count_runs(const std::string& study_id);
  /// The stored trace of a run; nullopt when the run has none (or does not exist).
  std::optional<std::vector<TracePoint>> get_trace(const std::string& study_id,
                                                   std::int64_t design_index);

  // --- diagnoses (schema version 2) ---
  /// Inserts a diagnosis in state queued; atomic with respect to the idempotency key like
  /// create_study. Throws StoreError when the id exists or request_json is not a JSON object.
  CreatedDiagnosis create_diagnosis(const NewDiagnosis& new_diagnosis);
  /// The row with its result (nullopt for an unknown id).
  std::optional<DiagnosisRecord> get_diagnosis(const std::string& id);
  /// The stored request_json, or nullopt for an unknown id.
  std::optional<std::string> get_diagnosis_request(const std::string& id);
  std::optional<DiagnosisRecord> find_diagnosis_by_idempotency_key(const std::string& key);
  /// Keyset pagination in id order, without results (result_json left empty).
  std::vector<DiagnosisRecord> list_diagnoses(std::size_t page_size,
                                              const std::string& after_id = "");
  /// As set_study_state, for a diagnosis. Throws StoreError for an unknown id.
  void set_diagnosis_state(const std::string& id, StudyState state,
                           const std::optional<std::string>& error = std::nullopt);
  /// running -> queued (a worker stopped by shutdown); returns whether the state changed.
  bool requeue_diagnosis(const std::string& id);
  /// Stores the outcome of a run (state succeeded with result_json, or failed with error) in
  /// one statement, but only while the diagnosis is queued or running: returns false, changing
  /// nothing, when it was cancelled (or finished) meanwhile.
  /// traces (one per run, in manifest order) are stored in the same transaction as the
  /// outcome, replacing any stored before; the lengths of a trace's series must agree (extended
  /// may be empty), else StoreError and nothing changes.
  bool finish_diagnosis(const std::string& id, StudyState state,
                        const std::optional<std::string>& result_json,
                        const std::optional<std::string>& error = std::nullopt,
                        const std::vector<DiagnosisTrace>& traces = {});
  /// The stored traces of a diagnosis, in run order (empty: none stored, or no such diagnosis).
  std::vector<DiagnosisTraceInfo> list_diagnosis_traces(const std::string& id);
  /// One run's stored trace; nullopt when it has none.
  std::optional<DiagnosisTrace> get_diagnosis_trace(const std::string& id,
                                                    std::int64_t run_index);

  struct Impl;

 private:
  explicit Store(std::unique_ptr<Impl> impl) noexcept;
  std::unique_ptr<Impl> impl_;
};

struct WriterOptions {
  std::size_t max_batch = 64;                  ///< commit when this many runs are buffered
  std::chrono::milliseconds max_delay{500};    ///< ... or this long after the last commit
  std::chrono::milliseconds busy_timeout = Store::kDefaultBusyTimeout;
};

/// What one flush did.
struct FlushResult {
  std::size_t inserted = 0;    ///< new runs committed
  std::size_t duplicates = 0;  ///< already stored with the same param_hash: left untouched
};

/// The single writer of runs (see the threading contract above). Owns its own connection.
class RunWriter {
 public:
  /// Opens path like Store::open(path, kReadWriteCreate) on a new connection.
  static RunWriter open(const std::filesystem::path& path, WriterOptions options = {});

  RunWriter(RunWriter&&) noexcept;
  RunWriter& operator=(RunWriter&&) noexcept;  ///< flushes the target first, like ~RunWriter
  RunWriter(const RunWriter&) = delete;
  RunWriter& operator=(const RunWriter&) = delete;
  /// Flushes; never throws (a failure is reported on stderr and the buffer is lost).
  ~RunWriter();

  /// Validates and buffers a run (throws StoreError for a bad record: empty study_id, negative
  /// design_index, unknown status, params_json not a JSON object, bad or repeated stage
  /// numbers), then flushes if the batch is full or due. The flush may throw (see flush()),
  /// except for a busy store: then the runs stay buffered and the commit is tried again later.
  void add(RunRecord run);
  /// Commits the buffer if it holds max_batch runs or max_delay has passed since the last
  /// commit (or since open); returns whether it committed. A busy store (StoreFault::kBusy)
  /// does not throw: the runs stay buffered, and the next attempt waits 50 ms, doubling to 2 s.
  bool flush_if_due();
  /// Commits all buffered runs in ONE transaction; each run with its stage metrics and trace.
  /// A run whose (study_id, design_index) is already stored is not written again: with the same
  /// param_hash it counts as a duplicate; with a different one, or when a run violates a
  /// constraint (e.g. unknown study_id), it is left out, the others are committed, the buffer
  /// is cleared and StoreError lists the runs left out. On an SQLite failure (busy, I/O, disk
  /// full) the transaction is rolled back, the buffer kept for a retry, and StoreError thrown.
  FlushResult flush();

  std::size_t buffered() const noexcept;
  const std::filesystem::path& path() const noexcept;

  struct Impl;

 private:
  explicit RunWriter(std::unique_ptr<Impl> impl) noexcept;
  std::unique_ptr<Impl> impl_;
};

}  // namespace stickslip::store
