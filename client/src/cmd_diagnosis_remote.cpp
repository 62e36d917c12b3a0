// Diagnoses on a stickslipd server: `stickslip diagnose MANIFEST --server URL [--wait]` submits
// the manifest and its CSV contents (POST /v1/diagnoses); `stickslip diagnosis ID` shows,
// waits for, or cancels one. Exit codes (cli.h): 0 ok, 2 bad input (incl. 4xx replies),
// 3 server unreachable, 4 diagnosis failed or cancelled, 1 anything else.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <set>
#include <sstream>

#include "diagnose_remote.h"
#include "stickslip/client/cli.h"
#include "stickslip/client/remote.h"
#include "stickslip/common/json_schema.h"
#include "stickslip/measured/measured.h"

namespace stickslip::client {

using nlohmann::json;
namespace fs = std::filesystem;

namespace {

std::string slurp(const fs::path& path, const std::string& what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::invalid_argument("cannot read " + what + " \"" + path.string() + "\"");
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string number(const json& v) {
  if (!v.is_number()) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v.get<double>());
  return buf;
}

void print_diagnosis(const json& d) {
  std::cout << d.value("id", "") << "  " << d.value("name", "") << "  " << d.value("state", "")
            << "\n  created " << d.value("created_at", "");
  if (d["started_at"].is_string()) std::cout << "  started " << d["started_at"].get<std::string>();
  if (d["finished_at"].is_string())
    std::cout << "  finished " << d["finished_at"].get<std::string>();
  std::cout << "\n";
  if (d["error"].is_string()) std::cout << "  error: " << d["error"].get<std::string>() << "\n";
  const json& r = d.value("result", json());
  if (r.is_object()) {
    std::cout << "  base model " << r.value("base_model", "") << ", cause "
              << r.value("cause", "") << "\n  held-out RMSE base " << number(r["rmse_base_heldout"])
              << " N, extended " << number(r["rmse_extended_heldout"]) << " N, gain "
              << number(r["gain"]) << "\n";
  }
}

int final_code(const json& d) { return d.value("state", "") == "succeeded" ? kOk : kStudyFailed; }

/// Writes DIR/diagnosis.json once the diagnosis has a result.
void write_result(const json& d, const std::string& out, bool quiet) {
  if (out.empty() || !d["result"].is_object()) return;
  fs::create_directories(out);
  const fs::path file = fs::path(out) / "diagnosis.json";
  std::ofstream f(file);
  f << d["result"].dump(2) << "\n";
  if (!f.flush()) throw std::runtime_error("cannot write " + file.string());
  if (!quiet) std::cout << "wrote " << file.string() << "\n";
}

/// Waits (state changes on stderr), prints, writes DIR/diagnosis.json when asked.
int wait_and_report(Remote& remote, const std::string& id, bool json_output,
                    const std::string& out) {
  const json d = remote.wait_diagnosis(id, 1.0, [&](const json& s) {
    std::cerr << id << ": " << s.value("state", "") << "\n";
  });
  if (json_output) std::cout << d.dump(2) << "\n";
  else print_diagnosis(d);
  write_result(d, out, json_output);
  return final_code(d);
}

}  // namespace

Remote make_remote(const std::string& server) {
  const char* token = std::getenv("STICKSLIP_TOKEN");
  return Remote(ServerUrl::parse(server), token != nullptr ? token : "");
}

int guarded_remote(const std::function<int()>& body) {
  try {
    return body();
  } catch (const ApiError& e) {
    std::cerr << "stickslip: " << e.what() << "\n";
    return e.exit_code();
  } catch (const UnreachableError& e) {
    std::cerr << "stickslip: server unreachable: " << e.what() << "\n";
    return kUnreachable;
  } catch (const measured::MeasuredError& e) {
    std::cerr << "stickslip diagnose: " << e.what() << "\n";
    return kBadInput;
  } catch (const std::invalid_argument& e) {
    std::cerr << "stickslip: " << e.what() << "\n";
    return kBadInput;
  } catch (const std::exception& e) {
    std::cerr << "stickslip: " << e.what() << "\n";
    return kFailure;
  }
}

json diagnosis_request_from_files(const std::string& manifest, const json& options) {
  const std::string text = slurp(manifest, "manifest");
  std::vector<common::SpecError> errors;
  auto doc = common::parse_json(text, &errors);
  if (!doc) throw std::invalid_argument(manifest + ": " + common::to_string(errors));
  json files = json::object();
  const fs::path dir = fs::absolute(manifest).parent_path();
  if (doc->is_object() && (*doc)["runs"].is_array()) {
    for (auto& run : (*doc)["runs"]) {
      if (!run.is_object() || !run["file"].is_string()) continue;  // the server names it
      const fs::path file = run["file"].get<std::string>();
      const std::string name = file.filename().string();
      if (files.contains(name))
        throw std::invalid_argument("two runs have CSV files named \"" + name +
                                    "\"; the server receives files by base name");
      files[name] = slurp(file.is_relative() ? dir / file : file, "CSV file");
      run["file"] = name;
    }
  }
  json request = {{"manifest", std::move(*doc)}, {"files", std::move(files)}};
  if (!options.empty()) request["options"] = options;
  return request;
}

int remote_diagnose(const RemoteDiagnoseArgs& a) {
  return guarded_remote([&]() -> int {
    // The local checks first: their messages name the files on this machine.
    measured::load_measured(a.manifest);
    const json request = diagnosis_request_from_files(a.manifest, a.options);
    Remote remote = make_remote(a.server);
    const json d = remote.submit_diagnosis(request.dump(), a.idempotency_key);
    const std::string id = d.value("id", "");
    if (!a.wait) {
      if (a.json_output) std::cout << d.dump(2) << "\n";
      else std::cout << id << "\n";
      return kOk;
    }
    if (!a.json_output) std::cout << id << "\n" << std::flush;
    return wait_and_report(remote, id, a.json_output, a.out);
  });
}

void add_diagnosis_command(CLI::App& app, int& exit_code) {
  struct Args {
    std::string id, server = "http://127.0.0.1:8080", out;
    bool wait = false, cancel = false, json_output = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "diagnosis", "Show a diagnosis queued on a server with `stickslip diagnose --server`; "
                   "--wait waits for it (exit 4 if it fails), --cancel cancels it");
  cmd->add_option("ID", a->id, "diagnosis id (dg-...)")->required();
  cmd->add_option("--server", a->server, "stickslipd URL (token: $STICKSLIP_TOKEN)")
      ->envname("STICKSLIP_SERVER")
      ->capture_default_str();
  cmd->add_flag("--wait", a->wait, "wait until it finishes");
  cmd->add_flag("--cancel", a->cancel, "cancel it");
  cmd->add_option("--out", a->out, "once succeeded, write DIR/diagnosis.json");
  cmd->add_flag("--json", a->json_output, "machine-readable JSON on stdout");
  cmd->callback([a, &exit_code] {
    exit_code = guarded_remote([&]() -> int {
      Remote remote = make_remote(a->server);
      if (a->cancel) {
        const json d = remote.cancel_diagnosis(a->id);
        if (a->json_output) std::cout << d.dump(2) << "\n";
        else print_diagnosis(d);
        return kOk;
      }
      if (a->wait) return wait_and_report(remote, a->id, a->json_output, a->out);
      const json d = remote.diagnosis(a->id);
      if (a->json_output) std::cout << d.dump(2) << "\n";
      else print_diagnosis(d);
      write_result(d, a->out, a->json_output);
      return kOk;
    });
  });
}

}  // namespace stickslip::client
