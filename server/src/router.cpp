#include "stickslip/server/router.h"

#include <algorithm>
#include <stdexcept>
#include <string_view>

namespace stickslip::server {
namespace {

std::vector<std::string_view> split_path(std::string_view path) {
  std::vector<std::string_view> out;
  if (path.empty() || path.front() != '/') return out;
  path.remove_prefix(1);
  while (true) {
    const auto slash = path.find('/');
    out.push_back(path.substr(0, slash));
    if (slash == std::string_view::npos) break;
    path.remove_prefix(slash + 1);
  }
  return out;
}

bool match_segment(std::string_view pattern, std::string_view segment, PathParams* params) {
  if (pattern.empty() || pattern.front() != '{') return pattern == segment;
  const auto close = pattern.find('}');
  const std::string_view name = pattern.substr(1, close - 1);
  const std::string_view suffix = pattern.substr(close + 1);
  if (segment.size() <= suffix.size()) return false;
  if (segment.substr(segment.size() - suffix.size()) != suffix) return false;
  const std::string_view value = segment.substr(0, segment.size() - suffix.size());
  if (value.find(':') != std::string_view::npos) return false;
  if (params != nullptr) (*params)[std::string(name)] = std::string(value);
  return true;
}

}  // namespace

bool Router::match(const std::string& pattern, const std::string& path, PathParams* params) {
  const auto ps = split_path(pattern);
  const auto ss = split_path(path);
  if (ps.empty() || ps.size() != ss.size()) return false;
  PathParams found;
  for (std::size_t i = 0; i < ps.size(); ++i)
    if (!match_segment(ps[i], ss[i], &found)) return false;
  if (params != nullptr) *params = std::move(found);
  return true;
}

void Router::add(std::string method, std::string pattern, RouteHandler handler) {
  if (pattern.empty() || pattern.front() != '/')
    throw std::invalid_argument("route pattern must start with '/': " + pattern);
  for (const auto seg : split_path(pattern)) {
    if (!seg.empty() && seg.front() == '{') {
      const auto close = seg.find('}');
      if (close == std::string_view::npos || close < 2)
        throw std::invalid_argument("malformed parameter segment in route " + pattern);
    }
  }
  for (const auto& r : routes_)
    if (r.method == method && r.pattern == pattern)
      throw std::invalid_argument("duplicate route " + method + " " + pattern);
  routes_.push_back({std::move(method), std::move(pattern), std::move(handler)});
}

Response Router::route(const Request& request) const {
  const std::string path = request.path();
  std::vector<std::string> allowed;
  for (const auto& r : routes_) {
    PathParams params;
    if (!match(r.pattern, path, &params)) continue;
    if (r.method != request.method) {
      if (std::find(allowed.begin(), allowed.end(), r.method) == allowed.end())
        allowed.push_back(r.method);
      continue;
    }
    try {
      return r.handler(request, params);
    } catch (const std::exception& e) {
      return problem(500, "internal", "Internal server error",
                     std::string("the server failed to handle the request: ") + e.what(), {},
                     path);
    }
  }
  if (!allowed.empty()) {
    std::string allow;
    for (const auto& m : allowed) allow += (allow.empty() ? "" : ", ") + m;
    Response r = problem(405, "method-not-allowed", "Method not allowed",
                         "method " + request.method + " is not allowed on " + path +
                             "; allowed: " + allow,
                         {}, path);
    r.set_header("Allow", allow);
    return r;
  }
  return problem(404, "not-found", "Not found", "no route for " + path, {}, path);
}

}  // namespace stickslip::server
