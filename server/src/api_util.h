#pragma once
// Helpers shared by the handler files (private to the server library).

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "stickslip/common/json_schema.h"
#include "stickslip/server/http.h"
#include "stickslip/store/store.h"

namespace stickslip::server::detail {

enum class Format { kJson, kCsv };

/// Content negotiation for endpoints that serve JSON and CSV: the query parameter
/// format=json|csv wins, then the Accept header (absent or */*: JSON). nullopt: 406.
std::optional<Format> negotiate(const Request& r, bool csv_allowed);

/// A 406 problem listing what the endpoint serves.
Response not_acceptable(const Request& r, bool csv_allowed);

/// Parses an optional positive integer query parameter in [1, max]; on error returns the 400
/// problem in *error.
std::optional<std::size_t> page_size_param(const Request& r, std::size_t fallback,
                                           std::size_t max, Response* error);
/// The same for any integer parameter named name (e.g. max_points).
std::optional<std::size_t> page_size_param_named(const Request& r, const std::string& name,
                                                 std::size_t fallback, std::size_t max,
                                                 Response* error);

/// Page of a list keyed by id (studies, diagnoses): page_size (page_size_param) and the optional
/// page_token, the id to list after ("" when absent).
struct IdPage {
  std::size_t size = 0;
  std::string after;
};
/// nullopt with the 400 problem in *error when page_size is bad or page_token is not an id.
std::optional<IdPage> id_page_params(const Request& r, std::size_t fallback_size,
                                     std::size_t max_size, Response* error);

/// rows were read with a limit of page_size + 1 (one row more than a page, to know whether
/// another page follows): drops that extra row, and returns the next page token (the id of the
/// last row kept) or null when this is the last page.
template <class Row>
nlohmann::json take_id_page(std::vector<Row>& rows, std::size_t page_size) {
  if (rows.size() <= page_size) return nullptr;
  rows.resize(page_size);
  return rows.back().id;
}

/// The 400 for a page_token that is not one this endpoint returned.
Response bad_page_token(const Request& r);

/// One FieldError per error, each naming its pointer into the request body.
std::vector<FieldError> body_errors(const std::vector<common::SpecError>& errors);

/// Ids of studies and diagnoses: 1 to 128 of [A-Za-z0-9._-].
bool is_valid_id(const std::string& id);
/// Content-Type application/json (parameters such as charset ignored).
bool is_json_content_type(const std::string& value);
/// 400 when the Idempotency-Key header is present but not 1 to 255 visible ASCII characters.
std::optional<Response> check_idempotency_key(const Request& r, const std::string& instance);

/// 404 "<noun>-not-found": no job of this kind with this id.
Response unknown_job(const std::string& noun, const std::string& title, const std::string& id,
                     const std::string& instance);
Response unknown_study(const std::string& id, const std::string& instance);
Response store_failure(const store::StoreError& e, const std::string& instance);

/// A number, or null for NaN and infinities (JSON has neither).
nlohmann::json number_or_null(double v);
/// The shortest of %.15g..%.17g that reads back as v (0.1 -> "0.1").
std::string shortest_number(double v);
/// A CSV field: numbers with 17 significant digits, "" for NaN.
std::string csv_number(double v);
/// RFC 4180 quoting when the text holds a comma, quote or line break.
std::string csv_text(const std::string& text);

}  // namespace stickslip::server::detail
