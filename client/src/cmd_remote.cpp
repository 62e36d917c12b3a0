// The `stickslip` commands that drive a stickslipd server: submit, status, wait, runs, map,
// cancel, list. Exit codes (cli.h): 0 ok, 2 bad input (incl. 4xx replies), 3 server
// unreachable, 4 study failed or cancelled, 1 anything else.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include "stickslip/client/cli.h"
#include "stickslip/client/remote.h"
#include "local_store.h"
#include "stickslip/studies/map.h"

namespace stickslip::client {

using nlohmann::json;

namespace {

constexpr const char* kDefaultServer = "http://127.0.0.1:8080";

struct RemoteOptions {
  std::string server = kDefaultServer;
  bool json_output = false;
};

void add_common(CLI::App* cmd, RemoteOptions& o) {
  cmd->add_option("--server", o.server, "stickslipd URL (token: $STICKSLIP_TOKEN)")
      ->envname("STICKSLIP_SERVER")
      ->capture_default_str();
  cmd->add_flag("--json", o.json_output, "machine-readable JSON on stdout");
}

Remote make_remote(const RemoteOptions& o) {
  const char* token = std::getenv("STICKSLIP_TOKEN");
  return Remote(ServerUrl::parse(o.server), token != nullptr ? token : "");
}

/// Runs a command body, mapping errors to exit codes with a readable message on stderr.
void guarded(int& exit_code, const std::function<int()>& body) {
  try {
    exit_code = body();
  } catch (const ApiError& e) {
    std::cerr << "stickslip: " << e.what() << "\n";
    exit_code = e.exit_code();
  } catch (const UnreachableError& e) {
    std::cerr << "stickslip: server unreachable: " << e.what() << "\n";
    exit_code = kUnreachable;
  } catch (const std::invalid_argument& e) {
    std::cerr << "stickslip: " << e.what() << "\n";
    exit_code = kBadInput;
  } catch (const std::exception& e) {
    std::cerr << "stickslip: " << e.what() << "\n";
    exit_code = kFailure;
  }
}

std::string progress_text(const json& s) {
  const auto& p = s["progress"];
  std::ostringstream out;
  out << p.value("done", 0) << "/" << p.value("total", 0) << " runs";
  if (p.value("failed", 0) > 0) out << " (" << p.value("failed", 0) << " failed)";
  return out.str();
}

void print_study(const json& s) {
  std::cout << s.value("id", "") << "  " << s.value("name", "") << "  " << s.value("state", "")
            << "  " << progress_text(s) << "\n";
  std::cout << "  created " << s.value("created_at", "");
  if (s["started_at"].is_string()) std::cout << "  started " << s["started_at"].get<std::string>();
  if (s["finished_at"].is_string())
    std::cout << "  finished " << s["finished_at"].get<std::string>();
  std::cout << "\n";
  if (s["error"].is_string()) std::cout << "  error: " << s["error"].get<std::string>() << "\n";
}

int final_code(const json& s) {
  return s.value("state", "") == "succeeded" ? kOk : kStudyFailed;
}

/// Waits for a study: a progress bar on a terminal (stderr), plain lines otherwise.
json wait_for(Remote& remote, const std::string& id, double interval, bool quiet) {
  const bool tty = ::isatty(STDERR_FILENO) != 0;
  std::string last_line;
  const json s = remote.wait(id, interval, [&](const json& s) {
    if (quiet) return;
    const auto& p = s["progress"];
    const double total = std::max(1.0, p.value("total", 0) * 1.0);
    const double frac = p.value("done", 0) / total;
    if (tty) {
      constexpr int kWidth = 30;
      const int filled = static_cast<int>(std::round(frac * kWidth));
      std::fprintf(stderr, "\r[%s%s] %3.0f%% %s %s   ", std::string(filled, '#').c_str(),
                   std::string(kWidth - filled, '.').c_str(), 100 * frac,
                   progress_text(s).c_str(), s.value("state", "").c_str());
      std::fflush(stderr);
    } else {
      const std::string line = s.value("state", "") + " " + progress_text(s);
      if (line != last_line) std::cerr << id << ": " << line << "\n";
      last_line = line;
    }
  });
  if (tty && !quiet) std::fprintf(stderr, "\n");
  return s;
}

std::string cell(const json& v, int precision = 4) {
  if (!v.is_number()) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*g", precision, v.get<double>());
  return buf;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::invalid_argument("cannot read spec file \"" + path + "\"");
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void add_submit_command(CLI::App& app, int& exit_code) {
  auto o = std::make_shared<RemoteOptions>();
  auto spec = std::make_shared<std::string>();
  auto key = std::make_shared<std::string>();
  auto wait = std::make_shared<bool>(false);
  auto* cmd = app.add_subcommand("submit", "Submit a study spec to the server; prints its id");
  cmd->add_option("SPEC", *spec, "study spec (JSON, schemas/study.schema.json)")->required();
  cmd->add_flag("--wait", *wait, "wait until the study finishes (exit 4 if it fails)");
  cmd->add_option("--idempotency-key", *key, "retry-safe submission key");
  add_common(cmd, *o);
  cmd->callback([=, &exit_code] {
    guarded(exit_code, [&]() -> int {
      Remote remote = make_remote(*o);
      const json s = remote.submit(read_file(*spec), *key);
      const std::string id = s.value("id", "");
      if (!*wait) {
        if (o->json_output) std::cout << s.dump(2) << "\n";
        else std::cout << id << "\n";
        return kOk;
      }
      if (!o->json_output) std::cout << id << "\n" << std::flush;
      const json done = wait_for(remote, id, 0.5, false);
      if (o->json_output) std::cout << done.dump(2) << "\n";
      else print_study(done);
      return final_code(done);
    });
  });
}

void add_status_command(CLI::App& app, int& exit_code) {
  auto o = std::make_shared<RemoteOptions>();
  auto id = std::make_shared<std::string>();
  auto* cmd = app.add_subcommand("status", "Show a study's state and progress");
  cmd->add_option("ID", *id, "study id")->required();
  add_common(cmd, *o);
  cmd->callback([=, &exit_code] {
    guarded(exit_code, [&]() -> int {
      Remote remote = make_remote(*o);
      const json s = remote.study(*id);
      if (o->json_output) std::cout << s.dump(2) << "\n";
      else print_study(s);
      return kOk;
    });
  });
}

void add_wait_command(CLI::App& app, int& exit_code) {
  auto o = std::make_shared<RemoteOptions>();
  auto id = std::make_shared<std::string>();
  auto interval = std::make_shared<double>(0.5);
  auto* cmd = app.add_subcommand(
      "wait", "Wait for a study to finish (progress bar on a terminal); exit 4 if it fails");
  cmd->add_option("ID", *id, "study id")->required();
  cmd->add_option("--interval", *interval, "polling interval [s]")
      ->check(CLI::Range(0.05, 60.0))
      ->capture_default_str();
  add_common(cmd, *o);
  cmd->callback([=, &exit_code] {
    guarded(exit_code, [&]() -> int {
      Remote remote = make_remote(*o);
      const json s = wait_for(remote, *id, *interval, false);
      if (o->json_output) std::cout << s.dump(2) << "\n";
      else print_study(s);
      return final_code(s);
    });
  });
}

void add_runs_command(CLI::App& app, int& exit_code) {
  auto o = std::make_shared<RemoteOptions>();
  auto id = std::make_shared<std::string>();
  auto csv = std::make_shared<bool>(false);
  auto out = std::make_shared<std::string>("-");
  auto* cmd = app.add_subcommand("runs", "Print a study's run results");
  cmd->add_option("ID", *id, "study id")->required();
  cmd->add_flag("--csv", *csv, "CSV, one row per run and stage");
  cmd->add_option("--out", *out, "output file, - for stdout")->capture_default_str();
  add_common(cmd, *o);
  cmd->callback([=, &exit_code] {
    guarded(exit_code, [&]() -> int {
      Remote remote = make_remote(*o);
      if (*csv) {
        write_output(*out, remote.csv(*id, "runs"));
        return kOk;
      }
      const json runs = remote.runs_all(*id);
      if (o->json_output) {
        write_output(*out, runs.dump(2) + "\n");
        return kOk;
      }
      std::ostringstream t;
      char line[256];
      std::snprintf(line, sizeof line, "%6s %-18s %10s %-9s %12s %12s  %s\n", "index", "model",
                    "va/vd", "status", "amp s1 [N]", "amp s2 [N]", "error");
      t << line;
      for (const auto& r : runs) {
        const auto& st = r["stages"];
        std::snprintf(line, sizeof line, "%6lld %-18s %10s %-9s %12s %12s  %s\n",
                      r.value("design_index", 0LL),
                      r["model"].is_string() ? r["model"].get<std::string>().c_str() : "-",
                      cell(r["va_over_vd"]).c_str(), r.value("status", "").c_str(),
                      st.size() > 0 ? cell(st[0]["amplitude"]).c_str() : "-",
                      st.size() > 1 ? cell(st[1]["amplitude"]).c_str() : "-",
                      r["error"].is_string() ? r["error"].get<std::string>().c_str() : "");
        t << line;
      }
      write_output(*out, t.str());
      return kOk;
    });
  });
}

void add_cancel_command(CLI::App& app, int& exit_code) {
  auto o = std::make_shared<RemoteOptions>();
  auto id = std::make_shared<std::string>();
  auto* cmd = app.add_subcommand("cancel", "Cancel a study (its finished runs are kept)");
  cmd->add_option("ID", *id, "study id")->required();
  add_common(cmd, *o);
  cmd->callback([=, &exit_code] {
    guarded(exit_code, [&]() -> int {
      Remote remote = make_remote(*o);
      const json s = remote.cancel(*id);
      if (o->json_output) std::cout << s.dump(2) << "\n";
      else
        std::cout << *id << ": "
                  << (s.value("state", "") == "cancelled" ? "cancelled"
                                                          : "cancellation requested")
                  << " (" << progress_text(s) << " kept)\n";
      return kOk;
    });
  });
}

void add_list_command(CLI::App& app, int& exit_code) {
  auto o = std::make_shared<RemoteOptions>();
  auto* cmd = app.add_subcommand("list", "List the server's studies, oldest first");
  add_common(cmd, *o);
  cmd->callback([=, &exit_code] {
    guarded(exit_code, [&]() -> int {
      Remote remote = make_remote(*o);
      const json all = remote.list_all();
      if (o->json_output) {
        std::cout << all.dump(2) << "\n";
        return kOk;
      }
      for (const auto& s : all)
        std::printf("%-24s %-10s %-20s %s\n", s.value("id", "").c_str(),
                    s.value("state", "").c_str(), progress_text(s).c_str(),
                    s.value("name", "").c_str());
      return kOk;
    });
  });
}

}  // namespace

void add_remote_commands(CLI::App& app, int& exit_code) {
  add_submit_command(app, exit_code);
  add_status_command(app, exit_code);
  add_wait_command(app, exit_code);
  add_runs_command(app, exit_code);
  add_cancel_command(app, exit_code);
  add_list_command(app, exit_code);
}

int remote_map(const std::string& server, const std::string& id, const std::string& format,
               const std::string& out, const std::string& view) {
  int exit_code = kOk;
  guarded(exit_code, [&]() -> int {
    RemoteOptions o;
    o.server = server;
    Remote remote = make_remote(o);
    if (format == "csv") {
      write_output(out, remote.csv(id, "map"));
      return kOk;
    }
    const json m = remote.map(id);
    if (format == "json") {
      write_output(out, m.dump(2) + "\n");
      return kOk;
    }
    write_output(out, studies::map_to_table(studies::map_from_json(m), view == "mean_force"
                                                                  ? studies::MapView::kMeanForce
                                                                  : studies::MapView::kAmplitude));
    return kOk;
  });
  return exit_code;
}

}  // namespace stickslip::client
