#pragma once
// Transport-independent HTTP request and response values, so that every handler is a pure
// function Request -> Response that tests call without sockets (the Beast layer in
// http_server.h only converts to and from these).
//
// Errors are RFC 9457 problem details (application/problem+json):
//   {"type": "urn:stickslip:problem:<slug>", "title": ..., "status": 422, "detail": ...,
//    "instance": "/v1/studies", "errors": [{"pointer": "/base/m", "detail": "must be > 0, got -1"}]}
// Each entry of "errors" names the offending field with exactly one of "pointer" (RFC 6901 JSON
// Pointer into the request body), "parameter" (query parameter) or "header" (request header).

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace stickslip::server {

struct Header {
  std::string name;
  std::string value;
};

/// Case-insensitive ASCII comparison (HTTP field names and tokens).
bool iequals(std::string_view a, std::string_view b) noexcept;

/// Decodes %XX escapes (and '+' as space when plus_is_space). Invalid escapes are kept verbatim.
std::string percent_decode(std::string_view text, bool plus_is_space = false);

struct Request {
  std::string method;  ///< "GET", "POST", ...
  std::string target;  ///< origin-form request target, e.g. "/v1/studies?page_size=2"
  std::vector<Header> headers;
  std::string body;

  /// The value of the first header with this (case-insensitive) name.
  std::optional<std::string> header(std::string_view name) const;
  /// The percent-decoded path of target (without the query).
  std::string path() const;
  /// The query parameters, percent-decoded; a repeated name keeps its first value.
  std::map<std::string, std::string> query() const;
};

struct Response {
  int status = 200;
  std::vector<Header> headers;
  std::string body;

  /// Replaces the header with this name (or adds it).
  void set_header(std::string_view name, std::string value);
  std::optional<std::string> header(std::string_view name) const;
};

/// One offending field of a problem; exactly one of pointer / parameter / header is meaningful.
struct FieldError {
  enum class Where { kBody, kQuery, kHeader };
  Where where = Where::kBody;
  std::string name;  ///< JSON pointer (kBody), parameter name (kQuery) or header name (kHeader)
  std::string detail;
  static FieldError body(std::string pointer, std::string detail) {
    return {Where::kBody, std::move(pointer), std::move(detail)};
  }
  static FieldError query(std::string parameter, std::string detail) {
    return {Where::kQuery, std::move(parameter), std::move(detail)};
  }
  static FieldError header(std::string name, std::string detail) {
    return {Where::kHeader, std::move(name), std::move(detail)};
  }
};

/// A JSON response (Content-Type application/json), body = value.dump().
Response json_response(int status, const nlohmann::json& value);
/// A text response with the given content type.
Response text_response(int status, std::string content_type, std::string body);
/// An RFC 9457 problem response. slug names the problem type ("validation", "not-found", ...);
/// title is the same for every problem of a type, detail is specific to this occurrence.
Response problem(int status, std::string_view slug, std::string_view title, std::string detail,
                 const std::vector<FieldError>& errors = {}, std::string_view instance = "");

/// The standard reason phrase of a status code ("Not Found"), or "" if unknown.
std::string_view reason_phrase(int status) noexcept;

}  // namespace stickslip::server
