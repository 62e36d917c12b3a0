#pragma once
// A table of routes "METHOD /path/{param}" -> handler, matched segment by segment.
//
// Pattern segments are literals, "{name}" (any non-empty segment without ':'), or
// "{name}:verb" (a parameter followed by a literal suffix, Google AIP-136 custom methods such as
// "/v1/studies/{id}:cancel"). route() answers 404 problem+json when no pattern matches the path,
// and 405 with an Allow header when patterns match but none with the request's method.
// New endpoints (e.g. GET /v1/studies/{id}/indices, GET /v1/reports) are one add() each.

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "stickslip/server/http.h"

namespace stickslip::server {

using PathParams = std::map<std::string, std::string>;
using RouteHandler = std::function<Response(const Request&, const PathParams&)>;

struct Route {
  std::string method;   ///< "GET", "POST", ...
  std::string pattern;  ///< e.g. "/v1/studies/{id}/runs"
  RouteHandler handler;
};

class Router {
 public:
  /// Throws std::invalid_argument for a malformed pattern or a duplicate (method, pattern).
  void add(std::string method, std::string pattern, RouteHandler handler);
  /// Dispatches; never throws (a handler's exception becomes a 500 problem).
  Response route(const Request& request) const;
  /// Whether pattern matches path; fills params when it does.
  static bool match(const std::string& pattern, const std::string& path, PathParams* params);
  const std::vector<Route>& routes() const noexcept { return routes_; }

 private:
  std::vector<Route> routes_;
};

}  // namespace stickslip::server
