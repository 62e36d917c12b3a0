// `stickslip report`: the nightly report (reports/include/stickslip/reports/report.h,
// docs/report.md).
#include <csignal>
#include <fstream>
#include <iostream>
#include <sstream>

#include "execution.h"
#include "local_store.h"
#include "stickslip/client/cli.h"
#include "stickslip/reports/report.h"

namespace stickslip::client {
namespace {

namespace fs = std::filesystem;

std::atomic<bool> g_report_interrupted{false};
extern "C" void on_report_interrupt(int) { g_report_interrupted.store(true); }

struct ReportArgs {
  std::string config, out, db, date, gnuplot = "gnuplot";
  int threads = -1;
  bool quiet = false;
  ExecutionArgs execution;
  std::shared_ptr<studies::Executor> mpi;  ///< rank 0 of an MPI job: the MPI master
};

int make_report(const ReportArgs& a) {
  std::ifstream in(a.config, std::ios::binary);
  if (!in) {
    std::cerr << "stickslip report: cannot read config file '" << a.config << "'\n";
    return kBadInput;
  }
  std::stringstream text;
  text << in.rdbuf();
  fs::path dir = fs::path(a.config).parent_path();
  if (dir.empty()) dir = ".";
  const reports::ReportConfigResult parsed = reports::parse_report_config(text.str(), dir);
  if (!parsed.ok()) {
    std::cerr << "stickslip report: " << a.config << ": " << parsed.errors.size() << " error(s):\n";
    for (const auto& e : parsed.errors)
      std::cerr << "  " << (e.pointer.empty() ? "(document)" : e.pointer) << ": " << e.message
                << "\n";
    return kBadInput;
  }
  reports::ReportOptions opt;
  opt.db = a.db;
  opt.out_dir = a.out;
  opt.date = a.date;
  opt.threads = a.threads;
  opt.gnuplot = a.gnuplot;
  opt.stop = &g_report_interrupted;
  try {
    opt.execution = make_execution(a.execution, a.mpi);
  } catch (const std::invalid_argument& e) {
    std::cerr << "stickslip report: " << e.what() << "\n";
    return kBadInput;
  }
  std::string why;
  if (!opt.IsValid(&why)) {
    std::cerr << "stickslip report: " << why << "\n";
    return kBadInput;
  }
  std::string current;
  auto bar = std::make_shared<ProgressPrinter>(std::cerr);
  if (!a.quiet)
    opt.on_progress = [&](const std::string& entry, const studies::Progress& p) {
      if (entry != current) {
        bar->finish();
        bar = std::make_shared<ProgressPrinter>(std::cerr);
        current = entry;
        std::cerr << "entry " << entry << ": " << p.total << " runs\n";
      }
      bar->update(p.done, p.failed, p.total);
    };
  g_report_interrupted = false;
  std::signal(SIGINT, on_report_interrupt);
  std::signal(SIGTERM, on_report_interrupt);
  const reports::ReportResult r = reports::build_report(*parsed.config, opt);
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  bar->finish();
  if (!r.ok) {
    std::cerr << "stickslip report: " << r.error << "\n";
    return kFailure;
  }
  std::printf("report %s: %s (runs %.1f s, plots %.1f s, total %.1f s); %zu change(s) flagged "
              "since %s\n",
              r.dir.string().c_str(), r.html.string().c_str(), r.run_s, r.render_s, r.wall_s,
              r.flagged, r.previous_date ? r.previous_date->c_str() : "(no earlier report)");
  return kOk;
}

}  // namespace

void add_report_command(CLI::App& app, int& exit_code, std::shared_ptr<studies::Executor> mpi) {
  auto a = std::make_shared<ReportArgs>();
  a->mpi = mpi;
  CLI::App* cmd = app.add_subcommand(
      "report",
      "Run (or reuse, by spec hash) the studies of a report configuration in the local store and "
      "write OUT/<date>/index.html (self-contained) and OUT/<date>/summary.json, flagging changes "
      "since the previous report in OUT. Exit 0 when written, 2 for bad input, 1 on failure");
  cmd->add_option("--config", a->config, "report configuration (schemas/report.schema.json)")
      ->required();
  cmd->add_option("--out", a->out, "output directory (one subdirectory per date)")->required();
  add_db_option(cmd, a->db);
  cmd->add_option("--date", a->date, "report date YYYY-MM-DD (default: today, UTC)");
  cmd->add_option("--threads", a->threads, "OpenMP threads (default: the config's; 0: all cores)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--gnuplot", a->gnuplot, "gnuplot executable")->capture_default_str();
  cmd->add_flag("--quiet", a->quiet, "no progress output");
  add_execution_options(cmd, a->execution);
  cmd->callback([a, &exit_code] { exit_code = guarded("report", [&] { return make_report(*a); }); });
}

}  // namespace stickslip::client
