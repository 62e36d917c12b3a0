#include "api_util.h"

#include <charconv>
#include <cmath>
#include <cstdio>

namespace stickslip::server::detail {
namespace {

std::string trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return std::string(s);
}

}  // namespace

std::optional<Format> negotiate(const Request& r, bool csv_allowed) {
  const auto q = r.query();
  if (const auto f = q.find("format"); f != q.end()) {
    if (f->second == "json") return Format::kJson;
    if (f->second == "csv" && csv_allowed) return Format::kCsv;
    return std::nullopt;
  }
  const auto accept = r.header("Accept");
  if (!accept || trim(*accept).empty()) return Format::kJson;
  // Media ranges in order of appearance; q=0 excludes. (Preference weights are otherwise
  // ignored: clients of this API ask for one type.)
  std::string_view rest = *accept;
  while (!rest.empty()) {
    const auto comma = rest.find(',');
    std::string_view item = rest.substr(0, comma);
    rest = comma == std::string_view::npos ? std::string_view{} : rest.substr(comma + 1);
    const auto semi = item.find(';');
    const std::string type = trim(item.substr(0, semi));
    if (semi != std::string_view::npos) {
      const std::string params = trim(item.substr(semi + 1));
      if (params == "q=0" || params == "q=0.0" || params == "q=0.00" || params == "q=0.000")
        continue;
    }
    if (iequals(type, "application/json") || iequals(type, "application/*") ||
        iequals(type, "*/*"))
      return Format::kJson;
    if (csv_allowed && (iequals(type, "text/csv") || iequals(type, "text/*"))) return Format::kCsv;
  }
  return std::nullopt;
}

Response not_acceptable(const Request& r, bool csv_allowed) {
  const std::string served = csv_allowed ? "application/json, text/csv" : "application/json";
  return problem(406, "not-acceptable", "Not acceptable",
                 "this resource is served as " + served +
                     " (Accept header or query parameter format=json" +
                     (csv_allowed ? "|csv" : "") + ")",
                 {FieldError::header("Accept", "got \"" + r.header("Accept").value_or("") + "\"")},
                 r.path());
}

Response bad_page_token(const Request& r) {
  return problem(400, "invalid-parameter", "Invalid query parameter",
                 "page_token is not a token returned by this endpoint",
                 {FieldError::query("page_token", "not a token from next_page_token")}, r.path());
}

std::vector<FieldError> body_errors(const std::vector<common::SpecError>& errors) {
  std::vector<FieldError> out;
  for (const auto& e : errors) out.push_back(FieldError::body(e.pointer, e.message));
  return out;
}

std::optional<IdPage> id_page_params(const Request& r, std::size_t fallback_size,
                                     std::size_t max_size, Response* error) {
  const auto size = page_size_param(r, fallback_size, max_size, error);
  if (!size) return std::nullopt;
  const auto q = r.query();
  const auto t = q.find("page_token");
  if (t == q.end()) return IdPage{*size, ""};
  if (!is_valid_id(t->second)) {
    *error = bad_page_token(r);
    return std::nullopt;
  }
  return IdPage{*size, t->second};
}

std::optional<std::size_t> page_size_param(const Request& r, std::size_t fallback,
                                           std::size_t max, Response* error) {
  return page_size_param_named(r, "page_size", fallback, max, error);
}

std::optional<std::size_t> page_size_param_named(const Request& r, const std::string& name,
                                                 std::size_t fallback, std::size_t max,
                                                 Response* error) {
  const auto q = r.query();
  const auto it = q.find(name);
  if (it == q.end()) return fallback;
  std::size_t value = 0;
  const auto& s = it->second;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  if (ec != std::errc{} || end != s.data() + s.size() || value < 1 || value > max) {
    *error = problem(400, "invalid-parameter", "Invalid query parameter",
                     name + " must be an integer from 1 to " + std::to_string(max) + ", got \"" +
                         s + "\"",
                     {FieldError::query(name, "must be an integer from 1 to " +
                                                  std::to_string(max) + ", got \"" + s + "\"")},
                     r.path());
    return std::nullopt;
  }
  return value;
}

bool is_valid_id(const std::string& id) {
  if (id.empty() || id.size() > 128) return false;
  for (const char c : id) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '-' || c == '_' || c == '.';
    if (!ok) return false;
  }
  return true;
}

bool is_json_content_type(const std::string& value) {
  std::string_view v = value;
  const auto semi = v.find(';');
  v = v.substr(0, semi);
  while (!v.empty() && v.back() == ' ') v.remove_suffix(1);
  while (!v.empty() && v.front() == ' ') v.remove_prefix(1);
  return iequals(v, "application/json");
}

std::optional<Response> check_idempotency_key(const Request& r, const std::string& instance) {
  const auto key = r.header("Idempotency-Key");
  if (!key) return std::nullopt;
  bool ok = !key->empty() && key->size() <= 255;
  for (const char c : *key) ok = ok && c > ' ' && c <= '~';
  if (ok) return std::nullopt;
  return problem(400, "invalid-header", "Invalid header",
                 "Idempotency-Key must be 1 to 255 visible ASCII characters",
                 {FieldError::header("Idempotency-Key", "must be 1 to 255 visible ASCII characters")},
                 instance);
}

Response unknown_job(const std::string& noun, const std::string& title, const std::string& id,
                     const std::string& instance) {
  return problem(404, noun + "-not-found", title + " not found",
                 "no " + noun + " with id \"" + id + "\"", {}, instance);
}

Response unknown_study(const std::string& id, const std::string& instance) {
  return unknown_job("study", "Study", id, instance);
}

Response store_failure(const store::StoreError& e, const std::string& instance) {
  Response r = problem(503, "store-unavailable", "Store unavailable",
                       std::string("the study store failed: ") + e.what(), {}, instance);
  r.set_header("Retry-After", "1");
  return r;
}

nlohmann::json number_or_null(double v) {
  if (!std::isfinite(v)) return nullptr;
  return v;
}

std::string csv_number(double v) {
  if (std::isnan(v)) return "";
  return shortest_number(v);
}

std::string csv_text(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

}  // namespace stickslip::server::detail
