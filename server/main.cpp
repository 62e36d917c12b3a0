// stickslipd: the stickslip job server. Thin main: options, then Api + Worker + HttpServer.
//
// Signals: SIGTERM / SIGINT stop accepting connections, stop the worker (no new run starts; the
// runs in progress finish and are committed; the study stays queued and resumes on the next
// start), then the server exits 0. A running diagnosis is put back to queued and gets
// --diagnosis-grace seconds to finish (its result is then stored); otherwise the server exits 0
// without it and the next start reruns it.
#include <pthread.h>
#include <signal.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>

#include "stickslip/common/text.h"
#include "stickslip/server/api.h"
#include "stickslip/server/diagnosis_worker.h"
#include "stickslip/server/validation_worker.h"
#include "stickslip/server/http_server.h"
#include "stickslip/server/worker.h"
#include "stickslip/store/writer_lock.h"
#include "stickslip/studies/launcher.h"
#include "stickslip/studies/runner.h"

namespace {

namespace fs = std::filesystem;
using namespace stickslip;

/// Writes text to path atomically (temporary file + rename), so a reader never sees half a port.
void write_atomically(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    if (!out) throw std::runtime_error("cannot write " + tmp.string());
    out << text;
    if (!out.flush()) throw std::runtime_error("cannot write " + tmp.string());
  }
  fs::rename(tmp, path);
}

/// Everything the command line sets.
struct Daemon {
  server::ApiOptions api;
  server::ServerOptions net;
  server::WorkerOptions work;
  server::DiagnosisWorkerOptions diag;
  studies::LauncherOptions launch;
  std::string db = "stickslip.db";
  std::string port_file;
  std::string log_level = "info";
  int read_timeout_s = 10, idle_timeout_s = 30;
  long long min_poll_interval_ms = net.min_poll_interval.count();
  int diagnosis_grace_s = 5;
  int study_cache_ms = 100;
  Daemon() {
    work.execution.retries = 2;
    launch.program = studies::sibling_program("stickslip");
  }
};

/// The store, the address and the token.
void add_http_options(CLI::App& app, Daemon& o) {
  app.add_option("--db", o.db, "SQLite store (created if missing)")->capture_default_str();
  app.add_option("--bind", o.net.bind, "address to listen on")->capture_default_str();
  app.add_option("--port", o.net.port, "TCP port; 0 = an ephemeral port (see --port-file)")
      ->capture_default_str();
  app.add_option("--port-file", o.port_file, "write the bound port to this file once listening");
  app.add_option("--token", o.api.token,
                 "bearer token required on state-changing endpoints (default: $STICKSLIP_TOKEN; "
                 "none: no authentication)")
      ->envname("STICKSLIP_TOKEN");
  app.add_option("--reports", o.api.reports_dir,
                 "directory of `stickslip report --out` reports, served at /v1/reports");
}

/// The workers, limits, HTTP timeouts and the MPI launcher (in the order --help lists them).
void add_job_and_limit_options(CLI::App& app, Daemon& o) {
  app.add_option("--workers", o.work.concurrency, "studies run at once")->capture_default_str();
  app.add_option("--threads", o.work.threads, "OpenMP threads per study (0 = all cores)")
      ->capture_default_str();
  app.add_option("--worker-nice", o.work.nice,
                 "nice increment (0-19) of the study threads over the process's nice")
      ->capture_default_str();
  app.add_option("--io-nice", o.net.io_nice,
                 "nice increment (0-19) of the HTTP I/O and handler threads over the process's "
                 "nice; > 0 favours a running study over API latency")
      ->capture_default_str();
  app.add_option("--io-slice-us", o.net.io_slice_us,
                 "scheduler slice of the HTTP threads [us] (Linux >= 6.12): shorter = lower "
                 "latency at the same share of the CPU; 0 = the kernel's default")
      ->capture_default_str();
  app.add_option("--min-poll-interval-ms", o.min_poll_interval_ms,
                 "a GET repeated on the same connection within this time of the previous answer "
                 "waits out the rest (0-10000 ms; 0 = no pacing): bounds what back-to-back "
                 "pollers take from a running study")
      ->capture_default_str();
  app.add_option("--max-runs", o.api.limits.max_runs, "largest number of runs of one study")
      ->capture_default_str();
  app.add_option("--max-body", o.api.max_body_bytes, "largest request body [bytes]")
      ->capture_default_str();
  app.add_option("--max-diagnosis-body", o.api.max_diagnosis_body_bytes,
                 "largest POST /v1/diagnoses body (manifest + CSV contents) [bytes]")
      ->capture_default_str();
  app.add_option("--diagnosis-threads", o.diag.threads,
                 "OpenMP threads per diagnosis (0 = all cores)")
      ->capture_default_str();
  app.add_option("--diagnosis-grace", o.diagnosis_grace_s,
                 "on SIGTERM, how long a running diagnosis may still finish before the server "
                 "exits anyway (it stays queued and reruns on the next start) [s]")
      ->capture_default_str()
      ->check(CLI::Range(0, 3600));
  app.add_option("--max-connections", o.net.max_connections, "concurrent connections")
      ->capture_default_str();
  app.add_option("--read-timeout", o.read_timeout_s, "time to receive one request [s]")
      ->capture_default_str();
  app.add_option("--idle-timeout", o.idle_timeout_s, "keep-alive idle time [s]")
      ->capture_default_str();
  app.add_option("--io-threads", o.net.io_threads, "I/O threads")->capture_default_str();
  app.add_option("--handler-threads", o.net.handler_threads, "request handler threads")
      ->capture_default_str();
  app.add_option("--study-cache-ms", o.study_cache_ms,
                 "GET /v1/studies/{id} may answer from a cache this old [ms] (0 = off)")
      ->capture_default_str()
      ->check(CLI::Range(0, 10000));
  app.add_option("--log-level", o.log_level, "trace, debug, info, warn, error")
      ->capture_default_str();
  app.add_option("--launcher", o.launch.command,
                 "run each study as one MPI job started with this command prefix, e.g. "
                 "\"mpirun -np 8 --hostfile hosts\" or \"srun -n 64\" (docs/scale.md); this "
                 "server stays the store's one writer. Default: OpenMP in this process");
  app.add_option("--launcher-program", o.launch.program,
                 "the stickslip executable the MPI job runs (the same path on every node)")
      ->capture_default_str();
  app.add_option("--launcher-retries", o.work.execution.retries,
                 "with --launcher: start a study's job again this many times after it lost a "
                 "rank (each time for the missing runs) before the study fails")
      ->capture_default_str()
      ->check(CLI::Range(0, 100));
  app.add_option("--chunk-deadline", o.work.execution.chunk_deadline_s,
                 "with --launcher: a chunk of runs not returned within max(this, 10 x its "
                 "expected time) means its rank hung or was lost [s] (0: 120 s)")
      ->check(CLI::Range(0.0, 1e7));
}

/// Derived settings, once the command line is parsed.
void finish_options(Daemon& o) {
  spdlog::set_level(spdlog::level::from_str(o.log_level));
  o.api.db = o.db;
  o.api.study_cache_ttl = std::chrono::milliseconds(o.study_cache_ms);
  o.net.max_body_bytes = o.api.max_body_bytes;
  o.net.path_body_limits["/v1/diagnoses"] = o.api.max_diagnosis_body_bytes;
  o.net.path_body_limits["/v1/validations"] = o.api.max_diagnosis_body_bytes;
  o.api.diagnosis_threads = o.diag.threads;
  o.diag.nice = o.work.nice;
  o.net.read_timeout = std::chrono::seconds(o.read_timeout_s);
  o.net.idle_timeout = std::chrono::seconds(o.idle_timeout_s);
  o.net.min_poll_interval = std::chrono::milliseconds(o.min_poll_interval_ms);
  o.work.limits = o.api.limits;
}

/// Every broken option of the three option sets, each message once (diag takes some values
/// from work, --worker-nice).
std::vector<std::string> option_errors(const Daemon& o) {
  std::vector<std::string> errors;
  o.net.IsValid(&errors);
  o.work.IsValid(&errors);
  o.diag.IsValid(&errors);
  std::set<std::string> seen;
  std::erase_if(errors, [&seen](const std::string& e) { return !seen.insert(e).second; });
  return errors;
}

/// Serves until SIGTERM or SIGINT (blocked in every thread; taken here with sigwait).
int serve(Daemon& o, const sigset_t& signals) {
  if (!o.launch.command.empty()) {
    o.launch.on_output = [](const std::string& line) { spdlog::info("launcher: {}", line); };
    o.work.execution.executor = studies::launcher_executor(o.launch);  // invalid: names the field
  } else {
    o.work.execution.retries = 0;
  }
  auto health = std::make_shared<server::Health>();
  server::Worker worker(o.api.db, o.work, &studies::run_study, health);
  server::DiagnosisWorker diagnoses(o.api.db, o.diag, &server::run_diagnosis, health);
  // Validations (POST /v1/validations) run on their own worker thread, with the diagnoses'
  // threads and nice value.
  server::ValidationWorkerOptions val;
  val.threads = o.diag.threads;
  val.nice = o.diag.nice;
  server::ValidationWorker validations(o.api.db, val, health);
  // Opens the store: takes its writer lock (a store has one writer; another holder is named
  // in the error, exit 1) and checks a damaged file before anything is written to it.
  server::Api handlers(o.api, &worker, &diagnoses, health, &validations);
  store::WriterLock lock = store::WriterLock::acquire(o.api.db, "stickslipd");
  server::HttpServer http(
      o.net, [&handlers](const server::Request& r) { return handlers.handle(r); },
      [&handlers](const server::Request& r) { return handlers.handle_cached(r); });
  const unsigned short port = http.port();
  lock.set_url("http://" + o.net.bind + ":" + std::to_string(port));
  if (!o.port_file.empty()) write_atomically(o.port_file, std::to_string(port) + "\n");
  std::printf("stickslipd listening on http://%s:%u (store %s)\n", o.net.bind.c_str(), port,
              o.db.c_str());
  std::fflush(stdout);
  http.start();
  worker.start();
  diagnoses.start();
  validations.start();

  int sig = 0;
  sigwait(&signals, &sig);
  spdlog::info("{}: stop accepting; waiting for the running batch to commit",
               sig == SIGTERM ? "SIGTERM" : "SIGINT");
  http.stop_accepting();
  worker.shutdown();
  const bool diagnosis_ended = diagnoses.shutdown(std::chrono::seconds(o.diagnosis_grace_s)) &
                               validations.shutdown(std::chrono::seconds(o.diagnosis_grace_s));
  http.stop();
  if (!diagnosis_ended) {
    // The running diagnosis cannot be interrupted and is already back in the queue; its
    // thread was detached, so leave without running destructors under it.
    spdlog::info("stopped (a running diagnosis was left queued; it reruns on the next start)");
    spdlog::default_logger()->flush();
    std::fflush(nullptr);
    std::_Exit(0);
  }
  spdlog::info("stopped");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"stickslipd: REST job server for stick-slip parameter studies (API: "
               "/v1/openapi.json)."};
  Daemon o;
  add_http_options(app, o);
  add_job_and_limit_options(app, o);
  CLI11_PARSE(app, argc, argv);
  finish_options(o);

  // Block the termination signals in every thread; serve() takes them with sigwait.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  try {
    if (const std::vector<std::string> errors = option_errors(o); !errors.empty()) {
      std::cerr << "stickslipd: " << common::join(errors, "; ") << "\n";
      return 2;
    }
    return serve(o, signals);
  } catch (const std::invalid_argument& e) {
    std::cerr << "stickslipd: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "stickslipd: " << e.what() << "\n";
    return 1;
  }
}
