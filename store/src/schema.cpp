// The schema of a stickslip database (version kStoreSchemaVersion; docs/store.md), creating it in
// an empty file and migrating an older version step by step.
#include <array>
#include <string>
#include <utility>

#include "connection.h"

namespace stickslip::store::detail {
namespace {

// ---------------------------------------------------------------------------------------------
// Schema (version kStoreSchemaVersion). Keep docs/store.md in step with this text.
// ---------------------------------------------------------------------------------------------

/// The runs table, written once: version 1 creates it under studies, version 4 rebuilds it under
/// jobs (SQLite cannot change a foreign key in place).
std::string runs_table_sql(const char* name, const char* parent) {
  return std::string("CREATE TABLE ") + name + " (\n  study_id     TEXT NOT NULL REFERENCES " +
         parent + R"sql( (id) ON DELETE CASCADE,
  design_index INTEGER NOT NULL CHECK (design_index >= 0),
  param_hash   TEXT NOT NULL,
  params_json  TEXT NOT NULL,
  model        TEXT,
  va_over_vd   REAL,
  status       TEXT NOT NULL CHECK (status IN ('ok', 'diverged', 'invalid')),
  error        TEXT,
  wall_time_s  REAL,
  t_end        REAL,
  steps        INTEGER NOT NULL,
  rmse         REAL,
  finished_at  TEXT NOT NULL,
  PRIMARY KEY (study_id, design_index)
);
)sql";
}

constexpr const char* kRunsIndexesSql = R"sql(
CREATE INDEX runs_study_model_va ON runs (study_id, model, va_over_vd);
CREATE INDEX runs_va_over_vd ON runs (va_over_vd);
CREATE INDEX runs_study_status ON runs (study_id, status);
CREATE INDEX runs_param_hash ON runs (param_hash);
)sql";

constexpr const char* kSchemaSql = R"sql(
CREATE TABLE meta (
  key   TEXT PRIMARY KEY NOT NULL,
  value TEXT NOT NULL
);

CREATE TABLE studies (
  id              TEXT PRIMARY KEY NOT NULL,
  name            TEXT NOT NULL,
  spec_json       TEXT NOT NULL,
  spec_hash       TEXT NOT NULL,
  state           TEXT NOT NULL DEFAULT 'queued'
                  CHECK (state IN ('queued', 'running', 'succeeded', 'failed', 'cancelled')),
  total_runs      INTEGER NOT NULL CHECK (total_runs >= 0),
  created_at      TEXT NOT NULL,
  started_at      TEXT,
  finished_at     TEXT,
  error           TEXT,
  idempotency_key TEXT UNIQUE,
  request_hash    TEXT
);

)sql";

constexpr const char* kSchemaTailSql = R"sql(
CREATE TABLE stage_metrics (
  study_id      TEXT NOT NULL,
  design_index  INTEGER NOT NULL,
  stage         INTEGER NOT NULL CHECK (stage >= 1),
  t_start       REAL,
  t_end         REAL,
  amplitude     REAL,
  amplitude_raw REAL,
  mean_force    REAL,
  mean_friction REAL,
  slip_events   INTEGER NOT NULL,
  mean_period   REAL,
  rmse          REAL,
  PRIMARY KEY (study_id, design_index, stage),
  FOREIGN KEY (study_id, design_index) REFERENCES runs (study_id, design_index)
    ON DELETE CASCADE
);

CREATE TABLE traces (
  study_id     TEXT NOT NULL,
  design_index INTEGER NOT NULL,
  n_samples    INTEGER NOT NULL CHECK (n_samples > 0),
  t            BLOB NOT NULL CHECK (length(t) = 8 * n_samples),
  F_d          BLOB NOT NULL CHECK (length(F_d) = 8 * n_samples),
  F_f          BLOB NOT NULL CHECK (length(F_f) = 8 * n_samples),
  x            BLOB NOT NULL CHECK (length(x) = 8 * n_samples),
  v            BLOB NOT NULL CHECK (length(v) = 8 * n_samples),
  s            BLOB NOT NULL CHECK (length(s) = 8 * n_samples),
  PRIMARY KEY (study_id, design_index),
  FOREIGN KEY (study_id, design_index) REFERENCES runs (study_id, design_index)
    ON DELETE CASCADE
);

CREATE VIEW v_run_metrics AS
SELECT r.study_id, r.design_index, r.model, r.va_over_vd, r.status, r.error, r.param_hash,
       r.params_json, r.wall_time_s, r.t_end AS run_t_end, r.steps, r.rmse AS run_rmse,
       m.stage, m.t_start, m.t_end, m.amplitude, m.amplitude_raw, m.mean_force,
       m.mean_friction, m.slip_events, m.mean_period, m.rmse
FROM runs AS r
LEFT JOIN stage_metrics AS m
  ON m.study_id = r.study_id AND m.design_index = r.design_index;

CREATE VIEW v_map AS
SELECT study_id, design_index, model, va_over_vd, stage, amplitude, mean_force, status
FROM v_run_metrics;

CREATE VIEW v_study_progress AS
SELECT s.id AS study_id, s.state, s.total_runs AS total,
       COUNT(r.design_index) AS done,
       COALESCE(SUM(r.status = 'ok'), 0) AS ok,
       COALESCE(SUM(r.status <> 'ok'), 0) AS failed
FROM studies AS s
LEFT JOIN runs AS r ON r.study_id = s.id
GROUP BY s.id;
)sql";

// Added in schema version 2 (a version-1 database gets it by migrate_step on its first
// read-write open). A diagnosis is one job: the request (manifest + CSV contents) in, the
// diagnosis.json document out.
constexpr const char* kDiagnosesSql = R"sql(
CREATE TABLE diagnoses (
  id              TEXT PRIMARY KEY NOT NULL,
  name            TEXT NOT NULL,
  request_json    TEXT NOT NULL,
  request_hash    TEXT NOT NULL,
  state           TEXT NOT NULL DEFAULT 'queued'
                  CHECK (state IN ('queued', 'running', 'succeeded', 'failed', 'cancelled')),
  created_at      TEXT NOT NULL,
  started_at      TEXT,
  finished_at     TEXT,
  error           TEXT,
  result_json     TEXT,
  idempotency_key TEXT UNIQUE
);
CREATE INDEX diagnoses_state ON diagnoses (state);
)sql";

// Added in schema version 3 (a version-2 database gets it by migrate_to_3; a new database runs
// the same statements, so a migrated file and a new one have the same schema). Each study row
// carries its run counters, kept by triggers in the transaction that writes or removes a run, so
// that v_study_progress (polled by every GET /v1/studies/{id}) reads one row instead of
// scanning all the study's runs: 1.9 ms for 3072 runs, growing linearly, with the version-2
// aggregate view (measured 2026-11-22).
constexpr const char* kRunCountersSql = R"sql(
ALTER TABLE studies ADD COLUMN runs_done INTEGER NOT NULL DEFAULT 0 CHECK (runs_done >= 0);
ALTER TABLE studies ADD COLUMN runs_ok INTEGER NOT NULL DEFAULT 0 CHECK (runs_ok >= 0);
ALTER TABLE studies ADD COLUMN runs_failed INTEGER NOT NULL DEFAULT 0 CHECK (runs_failed >= 0);
UPDATE studies SET
  runs_done = (SELECT COUNT(*) FROM runs WHERE runs.study_id = studies.id),
  runs_ok = (SELECT COUNT(*) FROM runs WHERE runs.study_id = studies.id AND runs.status = 'ok'),
  runs_failed = (SELECT COUNT(*) FROM runs WHERE runs.study_id = studies.id AND runs.status <> 'ok');

CREATE TRIGGER runs_count_insert AFTER INSERT ON runs BEGIN
  UPDATE studies SET runs_done = runs_done + 1,
                     runs_ok = runs_ok + (NEW.status = 'ok'),
                     runs_failed = runs_failed + (NEW.status <> 'ok')
  WHERE id = NEW.study_id;
END;
CREATE TRIGGER runs_count_delete AFTER DELETE ON runs BEGIN
  UPDATE studies SET runs_done = runs_done - 1,
                     runs_ok = runs_ok - (OLD.status = 'ok'),
                     runs_failed = runs_failed - (OLD.status <> 'ok')
  WHERE id = OLD.study_id;
END;
CREATE TRIGGER runs_count_update AFTER UPDATE OF study_id, status ON runs BEGIN
  UPDATE studies SET runs_done = runs_done - 1,
                     runs_ok = runs_ok - (OLD.status = 'ok'),
                     runs_failed = runs_failed - (OLD.status <> 'ok')
  WHERE id = OLD.study_id;
  UPDATE studies SET runs_done = runs_done + 1,
                     runs_ok = runs_ok + (NEW.status = 'ok'),
                     runs_failed = runs_failed + (NEW.status <> 'ok')
  WHERE id = NEW.study_id;
END;

DROP VIEW v_study_progress;
CREATE VIEW v_study_progress AS
SELECT id AS study_id, state, total_runs AS total, runs_done AS done, runs_ok AS ok,
       runs_failed AS failed
FROM studies;
)sql";

// Added in schema version 4 (a version-3 database gets it by migrate_step). The series of a
// diagnosis that `stickslip diagnose` plots per run (runK.png), stored with its outcome so that
// GET /v1/diagnoses/{id}/traces can serve them: each column n little-endian binary64 values like
// the traces table; extended is empty (zero bytes) when the diagnosis has no extended model.
// Written once: version 4 creates it under diagnoses, version 5 rebuilds it under jobs.
std::string diagnosis_traces_sql(const char* name, const char* parent) {
  return std::string("CREATE TABLE ") + name +
         " (\n  diagnosis_id TEXT NOT NULL REFERENCES " + parent + R"sql( (id) ON DELETE CASCADE,
  run_index    INTEGER NOT NULL CHECK (run_index >= 0),
  run          TEXT NOT NULL,
  n_samples    INTEGER NOT NULL CHECK (n_samples >= 0),
  t            BLOB NOT NULL CHECK (length(t) = 8 * n_samples),
  measured     BLOB NOT NULL CHECK (length(measured) = 8 * n_samples),
  base         BLOB NOT NULL CHECK (length(base) = 8 * n_samples),
  extended     BLOB NOT NULL CHECK (length(extended) IN (0, 8 * n_samples)),
  PRIMARY KEY (diagnosis_id, run_index)
);
)sql";
}

// Added in schema version 5 (a version-4 database gets it by migrate_step; a new database runs
// the same statements after versions 1-4, so a migrated file and a new one have the same
// schema). One jobs table for every kind of job replaces the studies and diagnoses tables: their
// rows are copied into it, runs is rebuilt to reference jobs (SQLite cannot change a foreign key
// in place), and `studies`, `diagnoses` and v_study_progress become views over jobs, so that
// queries written against versions 1-3 still read the same columns.
constexpr const char* kJobsSql = R"sql(
CREATE TABLE jobs (
  id               TEXT PRIMARY KEY NOT NULL,
  kind             TEXT NOT NULL CHECK (length(kind) > 0),
  name             TEXT NOT NULL,
  state            TEXT NOT NULL DEFAULT 'queued'
                   CHECK (state IN ('queued', 'running', 'succeeded', 'failed', 'cancelled')),
  request_json     TEXT NOT NULL,
  request_hash     TEXT NOT NULL,
  idempotency_key  TEXT,
  idempotency_hash TEXT,
  progress_total   INTEGER NOT NULL DEFAULT 0 CHECK (progress_total >= 0),
  progress_done    INTEGER NOT NULL DEFAULT 0 CHECK (progress_done >= 0),
  progress_failed  INTEGER NOT NULL DEFAULT 0 CHECK (progress_failed >= 0),
  result_json      TEXT,
  error            TEXT,
  created_at       TEXT NOT NULL,
  started_at       TEXT,
  finished_at      TEXT,
  UNIQUE (kind, idempotency_key)
);
CREATE INDEX jobs_kind ON jobs (kind, id);
CREATE INDEX jobs_name ON jobs (kind, name, id);
CREATE INDEX jobs_pending ON jobs (kind, id) WHERE state IN ('queued', 'running');

INSERT INTO jobs (id, kind, name, state, request_json, request_hash, idempotency_key,
                  idempotency_hash, progress_total, progress_done, progress_failed, result_json,
                  error, created_at, started_at, finished_at)
SELECT id, 'study', name, state, spec_json, spec_hash, idempotency_key, request_hash, total_runs,
       runs_done, runs_failed, NULL, error, created_at, started_at, finished_at
FROM studies;
INSERT INTO jobs (id, kind, name, state, request_json, request_hash, idempotency_key,
                  idempotency_hash, progress_total, progress_done, progress_failed, result_json,
                  error, created_at, started_at, finished_at)
SELECT id, 'diagnosis', name, state, request_json, request_hash, idempotency_key,
       CASE WHEN idempotency_key IS NULL THEN NULL ELSE request_hash END, 0, 0, 0, result_json,
       error, created_at, started_at, finished_at
FROM diagnoses;

DROP VIEW v_study_progress;
DROP TRIGGER runs_count_insert;
DROP TRIGGER runs_count_delete;
DROP TRIGGER runs_count_update;
)sql";

// Then runs_table_sql("runs_v5", "jobs"), and:
constexpr const char* kJobsCopyRunsSql = R"sql(
INSERT INTO runs_v5 (study_id, design_index, param_hash, params_json, model, va_over_vd, status,
                     error, wall_time_s, t_end, steps, rmse, finished_at)
SELECT study_id, design_index, param_hash, params_json, model, va_over_vd, status, error,
       wall_time_s, t_end, steps, rmse, finished_at
FROM runs;
DROP TABLE runs;
ALTER TABLE runs_v5 RENAME TO runs;
)sql";

// Then kRunsIndexesSql, diagnosis_traces_sql("diagnosis_traces_v5", "jobs"), and:
constexpr const char* kJobsCopyTracesSql = R"sql(
INSERT INTO diagnosis_traces_v5 (diagnosis_id, run_index, run, n_samples, t, measured, base,
                                 extended)
SELECT diagnosis_id, run_index, run, n_samples, t, measured, base, extended
FROM diagnosis_traces;
DROP TABLE diagnosis_traces;
ALTER TABLE diagnosis_traces_v5 RENAME TO diagnosis_traces;
)sql";

// Then:
constexpr const char* kJobsTailSql = R"sql(
DROP TABLE studies;
DROP TABLE diagnoses;

CREATE TRIGGER runs_count_insert AFTER INSERT ON runs BEGIN
  UPDATE jobs SET progress_done = progress_done + 1,
                  progress_failed = progress_failed + (NEW.status <> 'ok')
  WHERE id = NEW.study_id;
END;
CREATE TRIGGER runs_count_delete AFTER DELETE ON runs BEGIN
  UPDATE jobs SET progress_done = progress_done - 1,
                  progress_failed = progress_failed - (OLD.status <> 'ok')
  WHERE id = OLD.study_id;
END;
CREATE TRIGGER runs_count_update AFTER UPDATE OF study_id, status ON runs BEGIN
  UPDATE jobs SET progress_done = progress_done - 1,
                  progress_failed = progress_failed - (OLD.status <> 'ok')
  WHERE id = OLD.study_id;
  UPDATE jobs SET progress_done = progress_done + 1,
                  progress_failed = progress_failed + (NEW.status <> 'ok')
  WHERE id = NEW.study_id;
END;

CREATE VIEW studies AS
SELECT id, name, request_json AS spec_json, request_hash AS spec_hash, state,
       progress_total AS total_runs, created_at, started_at, finished_at, error,
       idempotency_key, idempotency_hash AS request_hash, progress_done AS runs_done,
       progress_done - progress_failed AS runs_ok, progress_failed AS runs_failed
FROM jobs WHERE kind = 'study';
CREATE TRIGGER studies_delete INSTEAD OF DELETE ON studies BEGIN
  DELETE FROM jobs WHERE id = OLD.id;
END;
CREATE TRIGGER studies_insert INSTEAD OF INSERT ON studies BEGIN
  INSERT INTO jobs (id, kind, name, state, request_json, request_hash, idempotency_key,
                    idempotency_hash, progress_total, error, created_at, started_at, finished_at)
  VALUES (NEW.id, 'study', NEW.name, coalesce(NEW.state, 'queued'), NEW.spec_json,
          NEW.spec_hash, NEW.idempotency_key, NEW.request_hash, NEW.total_runs, NEW.error,
          NEW.created_at, NEW.started_at, NEW.finished_at);
END;
CREATE VIEW diagnoses AS
SELECT id, name, request_json, request_hash, state, created_at, started_at, finished_at, error,
       result_json, idempotency_key
FROM jobs WHERE kind = 'diagnosis';
CREATE TRIGGER diagnoses_delete INSTEAD OF DELETE ON diagnoses BEGIN
  DELETE FROM jobs WHERE id = OLD.id;
END;
CREATE TRIGGER diagnoses_insert INSTEAD OF INSERT ON diagnoses BEGIN
  INSERT INTO jobs (id, kind, name, state, request_json, request_hash, idempotency_key,
                    idempotency_hash, result_json, error, created_at, started_at, finished_at)
  VALUES (NEW.id, 'diagnosis', NEW.name, coalesce(NEW.state, 'queued'), NEW.request_json,
          NEW.request_hash, NEW.idempotency_key,
          CASE WHEN NEW.idempotency_key IS NULL THEN NULL ELSE NEW.request_hash END,
          NEW.result_json, NEW.error, NEW.created_at, NEW.started_at, NEW.finished_at);
END;

CREATE VIEW v_study_progress AS
SELECT id AS study_id, state, progress_total AS total, progress_done AS done,
       progress_done - progress_failed AS ok, progress_failed AS failed
FROM jobs WHERE kind = 'study';
)sql";

// A read-only open of a version 1-3 file reads it as it is: these TEMP views (in the
// connection's own temp schema, so nothing is written to the file) give it the version-4 jobs
// table to read from. Version 1 has no diagnoses table (kJobsOfV1), versions 1-2 no run counters
// (counted from the runs).
constexpr const char* kJobsOfV3 = R"sql(
CREATE TEMP VIEW jobs AS
SELECT id, 'study' AS kind, name, state, spec_json AS request_json, spec_hash AS request_hash,
       idempotency_key, request_hash AS idempotency_hash, total_runs AS progress_total,
       runs_done AS progress_done, runs_failed AS progress_failed, NULL AS result_json, error,
       created_at, started_at, finished_at
FROM main.studies
UNION ALL
SELECT id, 'diagnosis', name, state, request_json, request_hash, idempotency_key,
       CASE WHEN idempotency_key IS NULL THEN NULL ELSE request_hash END, 0, 0, 0, result_json,
       error, created_at, started_at, finished_at
FROM main.diagnoses;
)sql";
constexpr const char* kStudyJobsOfV1V2 = R"sql(
SELECT s.id, 'study' AS kind, s.name, s.state, s.spec_json AS request_json,
       s.spec_hash AS request_hash, s.idempotency_key, s.request_hash AS idempotency_hash,
       s.total_runs AS progress_total,
       (SELECT count(*) FROM main.runs AS r WHERE r.study_id = s.id) AS progress_done,
       (SELECT count(*) FROM main.runs AS r WHERE r.study_id = s.id AND r.status <> 'ok')
         AS progress_failed,
       NULL AS result_json, s.error, s.created_at, s.started_at, s.finished_at
FROM main.studies AS s
)sql";

/// Version 1's tables and views (runs under studies).
void create_version_1(const Connection& conn) {
  conn.exec(kSchemaSql, "creating the schema");
  conn.exec((runs_table_sql("runs", "studies") + kRunsIndexesSql).c_str(), "creating runs");
  conn.exec(kSchemaTailSql, "creating the run metrics, traces and views");
}

/// Version 4 -> 5 (kJobsSql, then runs and diagnosis_traces rebuilt under jobs). The renames are
/// done with legacy_alter_table on, so that the views over runs (kept as they are) are not
/// checked while the table is missing for a moment; they read the new runs table afterwards.
void migrate_to_5(const Connection& conn) {
  conn.exec("PRAGMA legacy_alter_table = ON", "allowing the rename of runs");
  conn.exec(kJobsSql, "moving studies and diagnoses into the jobs table (schema version 5)");
  conn.exec(runs_table_sql("runs_v5", "jobs").c_str(), "creating runs under jobs");
  conn.exec(kJobsCopyRunsSql, "copying runs");
  conn.exec(kRunsIndexesSql, "indexing runs");
  conn.exec(diagnosis_traces_sql("diagnosis_traces_v5", "jobs").c_str(),
            "creating diagnosis_traces under jobs");
  conn.exec(kJobsCopyTracesSql, "copying the diagnosis traces");
  conn.exec(kJobsTailSql, "creating the views over jobs");
  conn.exec("PRAGMA legacy_alter_table = OFF", "restoring the rename rule");
}

std::string read_schema_version(const Connection& conn) {
  Statement st(conn, "SELECT value FROM meta WHERE key = 'schema_version'",
               "reading meta.schema_version");
  if (!st.step()) fail(conn.path(), "corrupt stickslip database: meta has no schema_version");
  return st.text(0);
}

/// One migration step from version `from` to from + 1 in one write transaction. Re-checks the
/// version inside the transaction, so two processes opening the same old file at once migrate
/// it once. Every existing table and row is kept as it is.
///  1 -> 2: adds the diagnoses table.
///  2 -> 3: adds the run counters of each study (filled from its runs), their triggers, and
///          v_study_progress reading them.
///  3 -> 4: adds the diagnosis_traces table (empty: older diagnoses have no stored traces).
///  4 -> 5: moves studies and diagnoses into the jobs table (migrate_to_5).
void migrate_step(const Connection& conn, int from) {
  const std::string step = "from version " + std::to_string(from) + " to " + std::to_string(from + 1);
  // Rebuilding runs drops the table other tables refer to: foreign keys must be off (they are
  // until configure() turns them on; a PRAGMA cannot change them inside the transaction).
  conn.exec("PRAGMA foreign_keys = OFF", "disabling foreign keys for the migration");
  Transaction tx(conn, Transaction::Kind::kWrite, "migrating the schema " + step);
  if (read_schema_version(conn) == std::to_string(from)) {
    if (from == 1) conn.exec(kDiagnosesSql, "creating the diagnoses table (schema version 2)");
    else if (from == 2) conn.exec(kRunCountersSql, "adding the run counters (schema version 3)");
    else if (from == 3)
      conn.exec(diagnosis_traces_sql("diagnosis_traces", "diagnoses").c_str(),
                "adding the diagnosis traces (schema version 4)");
    else migrate_to_5(conn);
    conn.exec(("UPDATE meta SET value = '" + std::to_string(from + 1) +
               "' WHERE key = 'schema_version'").c_str(),
              "writing meta.schema_version");
    Statement st(conn, "INSERT OR REPLACE INTO meta (key, value) VALUES ('migrated_at', ?1)",
                 "writing meta.migrated_at");
    st.bind_text(1, utc_now_iso8601()).run();
  }
  tx.commit("the schema migration " + step);
}

void write_schema(const Connection& conn) {
  create_version_1(conn);
  conn.exec(kDiagnosesSql, "creating the diagnoses table");
  conn.exec(kRunCountersSql, "adding the run counters");
  conn.exec(diagnosis_traces_sql("diagnosis_traces", "diagnoses").c_str(),
            "adding the diagnosis traces");
  migrate_to_5(conn);
  conn.exec(("PRAGMA application_id = " + std::to_string(kStoreApplicationId)).c_str(),
            "setting the application_id");
  Statement ins(conn, "INSERT INTO meta (key, value) VALUES (?1, ?2)", "writing meta");
  const std::array<std::pair<const char*, std::string>, 3> rows{{
      {"schema_version", std::to_string(kStoreSchemaVersion)},
      {"application", "stickslip"},
      {"created_at", utc_now_iso8601()},
  }};
  for (const auto& [key, value] : rows) ins.reset().bind_text(1, key).bind_text(2, value).run();
}

}  // namespace

/// Accepts this build's version; a read-write open migrates an older database step by step
/// (see migrate_step), a read-only open reads it as it is (version 1: studies and runs only;
/// versions 1 and 2 count runs with their aggregate view).
void require_schema_version(const Connection& conn, Store::Mode mode) {
  std::string value = read_schema_version(conn);
  for (int from = 1; from < kStoreSchemaVersion; ++from) {
    if (value != std::to_string(from)) continue;
    if (mode == Store::Mode::kReadOnly) return add_jobs_view(conn, from);
    migrate_step(conn, from);
    value = read_schema_version(conn);
  }
  if (value != std::to_string(kStoreSchemaVersion))
    fail(conn.path(), "stickslip schema_version " + value + " is not supported by this build "
                          "(it reads version " + std::to_string(kStoreSchemaVersion) +
                          ", and migrates versions 1 to " +
                          std::to_string(kStoreSchemaVersion - 1) + ")");
}

/// Initialises an empty database. Re-checks inside the write transaction, so two processes
/// creating the same file at once end up with one schema.
void initialise(const Connection& conn) {
  Transaction tx(conn, Transaction::Kind::kWrite, "initialising the database");
  const DbIdentity id = read_identity(conn);
  if (id.empty()) write_schema(conn);
  else if (!id.ours()) fail_foreign(conn.path(), id);
  tx.commit("the new schema");
}

void add_jobs_view(const Connection& conn, int version) {
  std::string sql;
  if (version >= 3) {
    sql = kJobsOfV3;
  } else {
    sql = std::string("CREATE TEMP VIEW jobs AS ") + kStudyJobsOfV1V2;
    if (version == 2)
      sql += "UNION ALL SELECT id, 'diagnosis', name, state, request_json, request_hash, "
             "idempotency_key, CASE WHEN idempotency_key IS NULL THEN NULL ELSE request_hash END, "
             "0, 0, 0, result_json, error, created_at, started_at, finished_at FROM main.diagnoses";
  }
  conn.exec(sql.c_str(), "reading schema version " + std::to_string(version) + " as it is");
}

}  // namespace stickslip::store::detail
