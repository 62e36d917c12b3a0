// Fuzz target: the HTTP request path without sockets: server::Api::handle, the pure function
// from a request to a response that the Beast transport calls (routing, authentication, query
// parameters, content negotiation, every handler, the store behind them). The API serves a
// store with 7 studies (one with 23 runs) and 3 diagnoses; its token is "fuzz-token".
// Input: "METHOD TARGET\n", then header lines "Name: value\n", an empty line, and the body.
// Properties (fuzz_support.h, check_response): handle never throws; every status is 2xx, 304 or
// 4xx (a 5xx means the server failed, never the request); a 4xx is problem+json whose "status"
// is the response's; a JSON response is JSON.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz_api.h"

namespace {

std::string_view take_line(std::string_view& rest) {
  const auto nl = rest.find('\n');
  std::string_view line = rest.substr(0, nl);
  rest = nl == std::string_view::npos ? std::string_view{} : rest.substr(nl + 1);
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  return line;
}

stickslip::server::Request parse_request(std::string_view in) {
  stickslip::server::Request r;
  const std::string_view first = take_line(in);
  const auto sp = first.find(' ');
  r.method = std::string(first.substr(0, sp));
  r.target = sp == std::string_view::npos ? "/" : std::string(first.substr(sp + 1));
  while (!in.empty()) {
    const std::string_view line = take_line(in);
    if (line.empty()) break;
    const auto colon = line.find(':');
    std::string_view value = colon == std::string_view::npos ? "" : line.substr(colon + 1);
    while (!value.empty() && value.front() == ' ') value.remove_prefix(1);
    r.headers.push_back({std::string(line.substr(0, colon)), std::string(value)});
  }
  r.body = std::string(in);
  return r;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace stickslip;
  auto& f = fuzz::api_fixture();
  const server::Request req = parse_request(std::string_view(reinterpret_cast<const char*>(data), size));
  const server::Response res = f.api->handle(req);
  fuzz::check_response(req, res);
  return 0;
}
