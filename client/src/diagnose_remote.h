#pragma once
// `stickslip diagnose MANIFEST --server URL` and `stickslip diagnosis ID` (private to the client).
#include <functional>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

namespace stickslip::client {

struct RemoteDiagnoseArgs {
  std::string server;           ///< stickslipd URL
  std::string manifest;         ///< manifest file; its CSVs are read relative to it
  nlohmann::json options;       ///< request "options" (only what the user set)
  std::string idempotency_key;  ///< "" = none
  std::string out;              ///< with wait: write DIR/diagnosis.json; "" = none
  bool wait = false;
  bool json_output = false;
};

/// Builds the request {"manifest", "files", "options"} from a manifest file: every run's CSV
/// is read (relative to the manifest) and sent under its base name, which replaces the run's
/// `file` in the manifest sent. Throws std::invalid_argument for an unreadable file or two runs
/// whose files have the same base name.
nlohmann::json diagnosis_request_from_files(const std::string& manifest,
                                            const nlohmann::json& options);

/// A Remote for the server URL with $STICKSLIP_TOKEN.
class Remote;
Remote make_remote(const std::string& server);

/// Runs body and turns the remote commands' errors into exit codes (cli.h), each printed.
int guarded_remote(const std::function<int()>& body);

/// Submits (and with wait, waits for) a diagnosis; returns the exit code.
int remote_diagnose(const RemoteDiagnoseArgs& args);

/// `stickslip diagnosis ID [--wait] [--cancel] [--out DIR] [--json] [--server URL]`.
void add_diagnosis_command(CLI::App& app, int& exit_code);

}  // namespace stickslip::client
