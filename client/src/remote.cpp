#include "stickslip/client/remote.h"

#include <algorithm>
#include <chrono>
#include <thread>

#include "stickslip/client/cli.h"

namespace stickslip::client {

using nlohmann::json;

bool is_terminal(const std::string& state) {
  return state == "succeeded" || state == "failed" || state == "cancelled";
}

std::string describe_error(const HttpReply& reply) {
  const std::string type = reply.header("Content-Type");
  if (type.rfind("application/problem+json", 0) == 0) {
    const json p = json::parse(reply.body, nullptr, false);
    if (p.is_object()) {
      std::string out = "server: " + std::to_string(reply.status) + " " +
                        p.value("title", std::string("error"));
      const auto& errors = p.contains("errors") ? p["errors"] : json::array();
      if (errors.empty()) {
        out += ": " + p.value("detail", std::string());
      } else {
        out += " (" + std::to_string(errors.size()) + " problem" +
               (errors.size() == 1 ? "" : "s") + "):";
        for (const auto& e : errors) {
          std::string where = e.contains("pointer")     ? e["pointer"].get<std::string>()
                              : e.contains("parameter") ? "query " + e["parameter"].get<std::string>()
                              : e.contains("header")    ? "header " + e["header"].get<std::string>()
                                                        : "";
          if (where.empty()) where = "(document)";
          out += "\n  " + where + ": " + e.value("detail", std::string());
        }
      }
      return out;
    }
  }
  std::string body = reply.body.substr(0, 500);
  return "server: HTTP " + std::to_string(reply.status) + (body.empty() ? "" : ": " + body);
}

Remote::Remote(ServerUrl server, std::string token)
    : server_(std::move(server)), token_(std::move(token)) {}

HttpReply Remote::call(HttpCall c, std::initializer_list<int> ok) {
  if (!token_.empty()) c.headers.emplace_back("Authorization", "Bearer " + token_);
  HttpReply reply = http_call(server_, c);
  if (std::find(ok.begin(), ok.end(), reply.status) == ok.end()) {
    // 4xx: the request (spec, id, token) is wrong; 5xx: the server failed.
    throw ApiError(reply.status >= 400 && reply.status < 500 ? kBadInput : kFailure,
                   describe_error(reply));
  }
  return reply;
}

namespace {
json parse_reply(const HttpReply& r) {
  json j = json::parse(r.body, nullptr, false);
  if (j.is_discarded()) throw ApiError(kFailure, "server: reply is not JSON: " + r.body.substr(0, 200));
  return j;
}
}  // namespace

json Remote::submit(const std::string& spec_json, const std::string& idempotency_key) {
  HttpCall c;
  c.method = "POST";
  c.target = "/v1/studies";
  c.body = spec_json;
  c.headers = {{"Content-Type", "application/json"}};
  if (!idempotency_key.empty()) c.headers.emplace_back("Idempotency-Key", idempotency_key);
  return parse_reply(call(c, {202}));
}

json Remote::study(const std::string& id) {
  return parse_reply(call({"GET", "/v1/studies/" + id, "", {}, std::chrono::seconds(30)}));
}

json Remote::cancel(const std::string& id) {
  HttpCall c;
  c.method = "POST";
  c.target = "/v1/studies/" + id + ":cancel";
  return parse_reply(call(c, {200, 202}));
}

json Remote::list_all(std::size_t page_size) {
  json all = json::array();
  std::string token;
  do {
    std::string target = "/v1/studies?page_size=" + std::to_string(page_size);
    if (!token.empty()) target += "&page_token=" + token;
    const json page = parse_reply(call({"GET", target, "", {}, std::chrono::seconds(30)}));
    for (const auto& s : page["studies"]) all.push_back(s);
    token = page["next_page_token"].is_string() ? page["next_page_token"].get<std::string>() : "";
  } while (!token.empty());
  return all;
}

json Remote::runs_all(const std::string& id) {
  json all = json::array();
  std::string token;
  do {
    std::string target = "/v1/studies/" + id + "/runs?page_size=1000";
    if (!token.empty()) target += "&page_token=" + token;
    const json page = parse_reply(call({"GET", target, "", {}, std::chrono::seconds(60)}));
    for (const auto& r : page["runs"]) all.push_back(r);
    token = page["next_page_token"].is_string() ? page["next_page_token"].get<std::string>() : "";
  } while (!token.empty());
  return all;
}

std::string Remote::csv(const std::string& id, const std::string& what) {
  return call({"GET", "/v1/studies/" + id + "/" + what, "", {{"Accept", "text/csv"}},
               std::chrono::seconds(120)})
      .body;
}

json Remote::map(const std::string& id) {
  return parse_reply(call({"GET", "/v1/studies/" + id + "/map", "", {}, std::chrono::seconds(120)}));
}

json Remote::wait(const std::string& id, double interval_s,
                  const std::function<void(const json&)>& on_progress) {
  json last;
  while (true) {
    json s = study(id);
    if (s != last && on_progress) on_progress(s);
    last = s;
    if (is_terminal(s.value("state", std::string()))) return s;
    std::this_thread::sleep_for(std::chrono::duration<double>(interval_s));
  }
}

json Remote::submit_diagnosis(const std::string& request_json, const std::string& idempotency_key) {
  return submit_job("/v1/diagnoses", request_json, idempotency_key);
}

json Remote::diagnosis(const std::string& id) { return job("/v1/diagnoses", id); }

json Remote::submit_job(const std::string& collection, const std::string& request_json,
                        const std::string& idempotency_key) {
  HttpCall c;
  c.method = "POST";
  c.target = collection;
  c.body = request_json;
  c.headers = {{"Content-Type", "application/json"}};
  c.timeout = std::chrono::seconds(300);  // the body may be tens of MB
  if (!idempotency_key.empty()) c.headers.emplace_back("Idempotency-Key", idempotency_key);
  return parse_reply(call(c, {202}));
}

json Remote::job(const std::string& collection, const std::string& id) {
  return parse_reply(call({"GET", collection + "/" + id, "", {}, std::chrono::seconds(30)}));
}

json Remote::wait_job(const std::string& collection, const std::string& id, double interval_s,
                      const std::function<void(const json&)>& on_change) {
  std::string last;
  while (true) {
    json d = job(collection, id);
    const std::string state = d.value("state", std::string());
    const std::string now = state + (d.contains("progress") ? d["progress"].dump() : "");
    if (now != last && on_change) on_change(d);
    last = now;
    if (is_terminal(state)) return d;
    std::this_thread::sleep_for(std::chrono::duration<double>(interval_s));
  }
}

std::string Remote::get_text(const std::string& target) {
  return call({"GET", target, "", {}, std::chrono::seconds(120)}).body;
}

json Remote::cancel_diagnosis(const std::string& id) {
  HttpCall c;
  c.method = "POST";
  c.target = "/v1/diagnoses/" + id + ":cancel";
  return parse_reply(call(c, {200}));
}

json Remote::wait_diagnosis(const std::string& id, double interval_s,
                            const std::function<void(const json&)>& on_change) {
  return wait_job("/v1/diagnoses", id, interval_s, on_change);
}

}  // namespace stickslip::client
