#pragma once
// The client side of stickslipd's API, shared by the `stickslip` commands that talk to a server:
// submit, status, wait, runs, map (with --server), cancel, list.

#include <functional>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "stickslip/client/http_client.h"

namespace stickslip::client {

/// A failed API call: its exit code (cli.h ExitCode) and a readable message that lists the
/// offending fields of a problem+json reply, one per line ("  /base/m: must be > 0, got -1").
class ApiError : public std::runtime_error {
 public:
  ApiError(int exit_code, const std::string& message)
      : std::runtime_error(message), exit_code_(exit_code) {}
  int exit_code() const noexcept { return exit_code_; }

 private:
  int exit_code_;
};

/// Formats an HTTP error reply: the problem's title, detail and fields when it is
/// application/problem+json, else the status and body.
std::string describe_error(const HttpReply& reply);

class Remote {
 public:
  /// token: bearer token for state-changing calls ("" = none; commands pass $STICKSLIP_TOKEN).
  Remote(ServerUrl server, std::string token);

  /// POST /v1/studies; returns the study resource.
  nlohmann::json submit(const std::string& spec_json, const std::string& idempotency_key = "");
  nlohmann::json study(const std::string& id);
  nlohmann::json cancel(const std::string& id);
  /// Every study, following next_page_token.
  nlohmann::json list_all(std::size_t page_size = 200);
  /// Every run as JSON, following next_page_token.
  nlohmann::json runs_all(const std::string& id);
  /// The runs or the map as CSV text.
  std::string csv(const std::string& id, const std::string& what);
  nlohmann::json map(const std::string& id);

  /// Polls the study until it is succeeded, failed or cancelled, calling on_progress with each
  /// new state of the resource. Returns the final resource.
  nlohmann::json wait(const std::string& id, double interval_s,
                      const std::function<void(const nlohmann::json&)>& on_progress);

  /// POST /v1/diagnoses with a request document (schemas/diagnosis_request.schema.json).
  nlohmann::json submit_diagnosis(const std::string& request_json,
                                  const std::string& idempotency_key = "");
  nlohmann::json diagnosis(const std::string& id);
  nlohmann::json cancel_diagnosis(const std::string& id);
  /// Polls the diagnosis until it is succeeded, failed or cancelled, calling on_change with
  /// each new state. Returns the final resource.
  nlohmann::json wait_diagnosis(const std::string& id, double interval_s,
                                const std::function<void(const nlohmann::json&)>& on_change);

  /// Any job collection ("/v1/validations"): POST a request document (202), GET one, poll until
  /// it is succeeded, failed or cancelled (on_change with each new state or progress), and GET a
  /// text resource (CSV).
  nlohmann::json submit_job(const std::string& collection, const std::string& request_json,
                            const std::string& idempotency_key = "");
  nlohmann::json job(const std::string& collection, const std::string& id);
  nlohmann::json wait_job(const std::string& collection, const std::string& id, double interval_s,
                          const std::function<void(const nlohmann::json&)>& on_change);
  std::string get_text(const std::string& target);

  const ServerUrl& server() const noexcept { return server_; }

 private:
  HttpReply call(HttpCall c, std::initializer_list<int> ok = {200});
  ServerUrl server_;
  std::string token_;
};

/// "queued", "running", ... -> true for succeeded, failed, cancelled.
bool is_terminal(const std::string& state);

}  // namespace stickslip::client
