// GET /v1/studies/{id}/indices (sensitivity indices of a stored Sobol or Morris study) and the
// nightly reports: GET /v1/reports, GET /v1/reports/{date}/{file}, GET /v1/reports/{date}/plots/{file}.
#include <cmath>
#include <fstream>
#include <map>
#include <type_traits>
#include <sstream>

#include "api_util.h"
#include "stickslip/server/dashboard.h"
#include "stickslip/server/api.h"
#include "stickslip/studies/indices.h"
#include "stickslip/reports/report.h"

namespace stickslip::server {

using detail::store_failure;
using detail::unknown_study;
using nlohmann::json;

namespace {

// Splits "a,b,,c" into {"a", "b", "c"}.
std::vector<std::string> split_list(const std::string& s) {
  std::vector<std::string> out;
  std::string cur;
  std::istringstream in(s);
  while (std::getline(in, cur, ','))
    if (!cur.empty()) out.push_back(cur);
  return out;
}

bool is_date(const std::string& d) {
  if (d.size() != 10 || d[4] != '-' || d[7] != '-') return false;
  for (std::size_t i = 0; i < d.size(); ++i)
    if (i != 4 && i != 7 && (d[i] < '0' || d[i] > '9')) return false;
  return true;
}

// A plain file name (no directory parts, no leading dot): the report's own files only.
bool is_plain_name(const std::string& n) {
  if (n.empty() || n.size() > 200 || n[0] == '.') return false;
  for (const char c : n)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
          c == '-' || c == '_' || c == '.'))
      return false;
  return true;
}

std::string content_type_of(const std::string& name) {
  const auto ends = [&](const char* ext) {
    const std::string e = ext;
    return name.size() >= e.size() && name.compare(name.size() - e.size(), e.size(), e) == 0;
  };
  if (ends(".html")) return "text/html; charset=utf-8";
  if (ends(".json")) return "application/json";
  if (ends(".svg")) return "image/svg+xml";
  if (ends(".png")) return "image/png";
  if (ends(".csv")) return "text/csv; charset=utf-8";
  return "application/octet-stream";
}

}  // namespace

namespace {

/// Reads the query parameters of GET /v1/studies/{id}/indices into opt; the errors name each
/// parameter and its value.
std::vector<FieldError> indices_query(const std::map<std::string, std::string>& q,
                                      studies::IndicesOptions* opt) {
  std::vector<FieldError> errors;
  auto number = [&](const char* key, auto* out) {
    const auto it = q.find(key);
    if (it == q.end()) return;
    try {
      std::size_t used = 0;
      const double v = std::stod(it->second, &used);
      if (used != it->second.size()) throw std::invalid_argument("trailing characters");
      using T = std::remove_pointer_t<decltype(out)>;
      if constexpr (std::is_integral_v<T>) {
        if (!(v >= 0 && v == std::floor(v) && v < 1e15)) throw std::invalid_argument("not a count");
      }
      *out = static_cast<std::remove_pointer_t<decltype(out)>>(v);
    } catch (const std::exception&) {
      errors.push_back(FieldError::query(key, "not a valid number: \"" + it->second + "\""));
    }
  };
  auto flag = [&](const char* key, bool* out) {
    const auto it = q.find(key);
    if (it == q.end()) return;
    if (it->second == "1" || it->second == "true") *out = true;
    else if (it->second == "0" || it->second == "false") *out = false;
    else errors.push_back(FieldError::query(key, "expected true or false, got \"" + it->second + "\""));
  };
  number("confidence", &opt->confidence);
  number("resamples", &opt->resamples);
  number("seed", &opt->seed);
  flag("keep_resamples", &opt->keep_resamples);
  flag("convergence", &opt->convergence);
  if (const auto it = q.find("method"); it != q.end()) opt->method = it->second;
  // One error per broken option, each at the query parameter its message starts with.
  if (std::vector<std::string> broken; errors.empty() && !opt->IsValid(&broken))
    for (const std::string& why : broken)
      errors.push_back(FieldError::query(why.substr(0, why.find(' ')), why));
  return errors;
}

}  // namespace

Response Api::get_indices(const Request& r, const std::string& id) const {
  const auto q = r.query();
  std::vector<std::string> outputs;
  if (const auto it = q.find("output"); it != q.end()) outputs = split_list(it->second);
  studies::IndicesOptions opt;
  if (const auto errors = indices_query(q, &opt); !errors.empty()) {
    std::string detail;
    for (const auto& e : errors) detail += (detail.empty() ? "" : "; ") + e.name + ": " + e.detail;
    return problem(400, "bad-parameter", "Bad query parameter", detail, errors, r.path());
  }
  try {
    auto store = pool_.acquire();
    if (!store->get_study(id)) return unknown_study(id, r.path());
    try {
      return json_response(200, studies::indices_json(*store, id, outputs, opt));
    } catch (const std::invalid_argument& e) {  // a design without indices, method, output name
      return problem(422, "no-indices", "Indices not available", e.what(),
                     {FieldError::query(opt.method.empty() ? "output" : "method", e.what())},
                     r.path());
    }
  } catch (const store::StoreError& e) {
    return store_failure(e, r.path());
  }
}

Response Api::list_reports(const Request& r) const {
  json list = json::array();
  if (!options_.reports_dir.empty())
    for (const std::string& d : reports::list_report_dates(options_.reports_dir))
      list.push_back({{"date", d},
                      {"html", "/v1/reports/" + d + "/index.html"},
                      {"summary", "/v1/reports/" + d + "/summary.json"}});
  (void)r;
  return json_response(200, {{"reports", list},
                             {"configured", !options_.reports_dir.empty()}});
}

Response Api::get_report_file(const Request& r, const std::string& date, const std::string& sub,
                              const std::string& name) const {
  if (!is_date(date))
    return problem(404, "not-found", "Not found", "no report dated \"" + date + "\"",
                   {FieldError::query("date", "expected YYYY-MM-DD")}, r.path());
  if (!is_plain_name(name))
    return problem(404, "not-found", "Not found", "no report file \"" + name + "\"", {}, r.path());
  if (options_.reports_dir.empty())
    return problem(404, "not-found", "Not found",
                   "this server serves no reports (start stickslipd with --reports DIR)", {},
                   r.path());
  const std::filesystem::path file = options_.reports_dir / date / sub / name;
  std::ifstream in(file, std::ios::binary);
  if (!in)
    return problem(404, "not-found", "Not found",
                   "no file \"" + (sub.empty() ? name : sub + "/" + name) + "\" in the report of " +
                       date,
                   {}, r.path());
  std::ostringstream body;
  body << in.rdbuf();
  Response resp = text_response(200, content_type_of(name), body.str());
  resp.set_header("Cache-Control", "public, max-age=300");
  // A report's page has an inline <style> and data: images, and no script: its own policy
  // (dashboard.h), which lets the dashboard embed it in a frame.
  resp.set_header("Content-Security-Policy", std::string(kReportContentSecurityPolicy));
  return resp;
}

}  // namespace stickslip::server
