// `stickslip study run|list|show|export`: studies in a local SQLite store.
#include <csignal>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>

#include "execution.h"
#include "local_store.h"
#include "stickslip/client/cli.h"
#include "stickslip/studies/export.h"
#include "stickslip/store/writer_lock.h"
#include "stickslip/studies/runner.h"

namespace stickslip::client {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// Set by SIGINT/SIGTERM while a study runs: stop starting runs, commit, exit (resumable).
// A lock-free atomic is the one kind of object a signal handler may write.
std::atomic<bool> g_interrupted{false};
static_assert(std::atomic<bool>::is_always_lock_free);
extern "C" void on_interrupt(int) { g_interrupted.store(true); }

struct RunArgs {
  std::string spec_file, db;
  int threads = 0;
  std::size_t max_runs = studies::Limits{}.max_runs;
  bool quiet = false, json_out = false;
  ExecutionArgs execution;
  std::shared_ptr<studies::Executor> mpi;  ///< rank 0 of an MPI job: the MPI master
};

/// Opens the store for `study run` and creates or finds the study. This command is the store's
/// one writer until it ends (writer_lock.h): a store that a server owns is refused, naming the
/// server and the command that submits the study to it, rather than run behind its back. A path
/// that cannot be created or a foreign file is bad input too, left untouched.
int open_for_run(const RunArgs& a, const studies::StudySpec& spec, store::StudyRecord* study,
                 std::optional<store::WriterLock>* lock) {
  try {
    store::Store store = store::Store::open(a.db);
    lock->emplace(store::WriterLock::acquire(a.db, "stickslip study run"));
    *study = studies::create_or_find_study(store, spec);
    return kOk;
  } catch (const store::StoreLockedError& e) {
    std::cerr << "stickslip study run: " << e.what() << "\n";
    if (e.holder() && !e.holder()->url.empty())
      std::cerr << "  submit the study to that server instead: stickslip submit " << a.spec_file
                << " --server " << e.holder()->url << "\n";
    return kBadInput;
  } catch (const store::StoreError& e) {
    std::cerr << "stickslip study run: " << e.what() << "\n";
    return kBadInput;
  }
}

int study_run(const RunArgs& a) {
  // 1. The spec: every problem is reported, nothing is written.
  std::ifstream in(a.spec_file, std::ios::binary);
  if (!in) {
    std::cerr << "stickslip study run: cannot read spec file '" << a.spec_file << "'\n";
    return kBadInput;
  }
  std::stringstream text;
  text << in.rdbuf();
  studies::Limits limits;
  limits.max_runs = a.max_runs;
  studies::ParseResult parsed = studies::parse_study(text.str(), limits);
  if (!parsed.ok()) {
    std::cerr << "stickslip study run: " << a.spec_file << ": " << parsed.errors.size()
              << " error(s):\n";
    for (const auto& e : parsed.errors)
      std::cerr << "  " << (e.pointer.empty() ? "(document)" : e.pointer) << ": " << e.message
                << "\n";
    return kBadInput;
  }
  const studies::StudySpec& spec = *parsed.spec;
  studies::Execution execution;
  try {
    execution = make_execution(a.execution, a.mpi);
  } catch (const std::invalid_argument& e) {
    std::cerr << "stickslip study run: " << e.what() << "\n";
    return kBadInput;
  }

  // 2. The store (open_for_run): a bad or busy store is bad input, left untouched.
  store::StudyRecord study;
  std::optional<store::WriterLock> lock;
  if (const int code = open_for_run(a, spec, &study, &lock); code != kOk) return code;
  if (!a.quiet)
    std::cerr << "study " << study.id << " (" << study.name << "): " << spec.run_count()
              << " runs, database " << a.db << "\n";

  // 3. Run what is missing.
  g_interrupted = false;
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  ProgressPrinter bar(std::cerr);
  studies::RunnerOptions opt;
  opt.threads = a.threads;
  opt.stop = &g_interrupted;
  opt.execution = execution;
  opt.on_retry = [&a](int attempt, const std::string& why) {
    if (!a.quiet)
      std::cerr << "\nstickslip study run: attempt " << attempt << " lost work (" << why
                << "); starting the job again for the missing runs\n";
  };
  opt.spec_dir = fs::path(a.spec_file).parent_path();
  if (opt.spec_dir.empty()) opt.spec_dir = ".";
  if (!a.quiet)
    opt.on_progress = [&bar](const studies::Progress& p) { bar.update(p.done, p.failed, p.total); };
  const studies::RunSummary sum = studies::run_study(a.db, study.id, spec, opt);
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  bar.finish();

  if (a.json_out) {
    std::cout << json{{"study_id", study.id},
                      {"outcome", studies::to_string(sum.outcome)},
                      {"error", sum.error},
                      {"total", sum.total},
                      {"skipped", sum.skipped},
                      {"computed", sum.computed},
                      {"failed", sum.failed},
                      {"batched", sum.batched},
                      {"wall_s", sum.wall_s},
                      {"store_s", sum.store_s},
                      {"compute_s", sum.compute_s}}
                     .dump(2)
              << "\n";
  } else {
    std::printf("study %s: %s; %lld runs: %lld stored before, %lld computed now (%lld failed); "
                "wall %.2f s, store %.3f s\n",
                study.id.c_str(), studies::to_string(sum.outcome),
                static_cast<long long>(sum.total), static_cast<long long>(sum.skipped),
                static_cast<long long>(sum.computed), static_cast<long long>(sum.failed),
                sum.wall_s, sum.store_s);
  }
  switch (sum.outcome) {
    case studies::RunOutcome::kCompleted: return kOk;
    case studies::RunOutcome::kStopped:
      std::cerr << "stickslip study run: interrupted; run the same command again to resume\n";
      return kFailure;
    case studies::RunOutcome::kCancelled: return kStudyFailed;
    case studies::RunOutcome::kFailed:
      std::cerr << "stickslip study run: " << sum.error << "\n";
      return kFailure;
  }
  return kFailure;
}

int study_list(const std::string& db, bool as_json) {
  store::Store store = open_existing(db);
  json all = json::array();
  if (!as_json)
    std::printf("%-24s %-24s %-10s %13s %7s  %s\n", "id", "name", "state", "done/total",
                "failed", "created");
  std::string after;
  while (true) {
    const auto page = store.list_studies(200, after);
    if (page.empty()) break;
    for (const auto& s : page) {
      const auto c = store.count_runs(s.id);
      if (as_json) {
        all.push_back(studies::study_to_json(s, c));
      } else {
        const std::string progress = std::to_string(c.done) + "/" + std::to_string(c.total);
        std::printf("%-24s %-24s %-10s %13s %7lld  %s\n", s.id.c_str(), s.name.c_str(),
                    store::to_string(s.state), progress.c_str(),
                    static_cast<long long>(c.failed), s.created_at.c_str());
      }
    }
    after = page.back().id;
  }
  if (as_json) std::cout << all.dump(2) << "\n";
  return kOk;
}

int study_show(const std::string& db, const std::string& id, bool with_spec) {
  store::Store store = open_existing(db);
  const store::StudyRecord s = resolve_study(store, id);
  json out = studies::study_to_json(s, store.count_runs(s.id));
  if (with_spec) out["spec"] = json::parse(s.spec_json);
  std::cout << out.dump(2) << "\n";
  return kOk;
}

int study_export(const std::string& db, const std::string& id, const std::string& format,
                 const std::string& out_path) {
  store::Store store = open_existing(db);
  const store::StudyRecord s = resolve_study(store, id);
  const std::size_t stages = json::parse(s.spec_json).value("stages", json::array()).size();
  std::ostringstream o;
  std::vector<std::string> names;
  bool first = true;
  json all = json::array();
  std::int64_t after = -1;
  while (true) {
    const auto runs = store.get_runs(s.id, after, 2000);
    if (runs.empty()) break;
    after = runs.back().design_index;
    if (format == "csv") {
      if (first) {
        names = studies::param_names_of(runs.front());
        o << studies::runs_csv_header(names, stages);
      }
      o << studies::runs_csv_rows(runs, names, stages);
    } else {
      for (const auto& r : runs) all.push_back(studies::run_to_json(r));
    }
    first = false;
  }
  if (format == "csv") {
    if (first) o << studies::runs_csv_header({}, stages);
    write_output(out_path, o.str());
  } else {
    json doc = studies::study_to_json(s, store.count_runs(s.id));
    doc["runs"] = all;
    write_output(out_path, doc.dump(2) + "\n");
  }
  return kOk;
}

}  // namespace

void add_study_command(CLI::App& app, int& exit_code, std::shared_ptr<studies::Executor> mpi) {
  CLI::App* study = app.add_subcommand("study", "Run and inspect studies in a local SQLite store");
  study->require_subcommand(1);

  auto ra = std::make_shared<RunArgs>();
  ra->mpi = mpi;
  CLI::App* run = study->add_subcommand(
      "run", "Create or resume a study from SPEC.json and compute its missing runs. Exit 0 when "
             "done, 2 for an invalid spec or database (nothing written), 1 on failure or "
             "interruption (run again to resume), 4 if cancelled");
  run->add_option("spec", ra->spec_file, "study specification (schemas/study.schema.json)")
      ->required();
  add_db_option(run, ra->db);
  run->add_option("--threads", ra->threads, "OpenMP threads (0: all cores)")
      ->check(CLI::NonNegativeNumber);
  run->add_option("--max-runs", ra->max_runs, "largest study accepted")->capture_default_str();
  run->add_flag("--quiet", ra->quiet, "no progress output");
  run->add_flag("--json", ra->json_out, "print the summary as JSON");
  add_execution_options(run, ra->execution);
  run->callback([ra, &exit_code] { exit_code = guarded("study run", [&] { return study_run(*ra); }); });

  add_compute_command(*study, exit_code, mpi);

  auto db = std::make_shared<std::string>();
  auto id = std::make_shared<std::string>();
  auto as_json = std::make_shared<bool>(false);
  CLI::App* list = study->add_subcommand("list", "List the studies in the database");
  add_db_option(list, *db);
  list->add_flag("--json", *as_json, "machine-readable output");
  list->callback([db, as_json, &exit_code] {
    exit_code = guarded("study list", [&] { return study_list(*db, *as_json); });
  });

  auto with_spec = std::make_shared<bool>(false);
  CLI::App* show = study->add_subcommand("show", "A study's state, progress and timestamps (JSON)");
  show->add_option("study", *id, "study id or name (newest of that name)")->required();
  add_db_option(show, *db);
  show->add_flag("--spec", *with_spec, "include the canonical spec");
  show->callback([db, id, with_spec, &exit_code] {
    exit_code = guarded("study show", [&] { return study_show(*db, *id, *with_spec); });
  });

  auto format = std::make_shared<std::string>("csv");
  auto out = std::make_shared<std::string>("-");
  CLI::App* exp = study->add_subcommand("export", "Every stored run with its metrics, as CSV or JSON");
  exp->add_option("study", *id, "study id or name")->required();
  add_db_option(exp, *db);
  exp->add_option("--format", *format, "csv or json")
      ->check(CLI::IsMember({"csv", "json"}))
      ->capture_default_str();
  exp->add_option("--out", *out, "output file, - for stdout")->capture_default_str();
  exp->callback([db, id, format, out, &exit_code] {
    exit_code = guarded("study export", [&] { return study_export(*db, *id, *format, *out); });
  });
}

}  // namespace stickslip::client
