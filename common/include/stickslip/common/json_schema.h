#pragma once
// Schema-agnostic JSON Schema validation (valijson, draft 7 semantics; schemas written as
// draft 2020-12 that avoid 2020-12-only keywords validate identically) that reports EVERY error,
// each with a JSON Pointer into the document and a readable message:
//   - every unknown field (additionalProperties: false) is named, one error each, with the
//     pointer of the field itself: "/design/foo": unknown field "foo" (allowed: type, axes);
//   - type, enum, const, bound, size and pattern messages are rewritten with the expected and the
//     actual value, e.g. "/base/m": must be > 0, got -1; "/design/axes/0/linspace": expected 3
//     numbers, got 2; "/base/model": must be one of "dahl", "lugre"; got "foo";
//   - valijson's wrapper messages ("Failed to validate item #0 in array.") are dropped when a more
//     specific error lies at or below their pointer.
// Also the JSON text parser used by every JSON input: it reports malformed JSON with line and
// column, and duplicate object keys (which JSON parsers otherwise silently resolve).

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace stickslip::common {

/// One problem in a JSON document. pointer is an RFC 6901 JSON Pointer ("" = the document).
struct SpecError {
  std::string pointer;
  std::string message;
  bool operator==(const SpecError&) const = default;
};

/// "pointer: message" (or just the message for the root pointer "").
std::string to_string(const SpecError& error);
/// All errors, one per line.
std::string to_string(const std::vector<SpecError>& errors);

/// Appends one reference token to a JSON Pointer, escaping '~' and '/'.
std::string pointer_append(std::string_view pointer, std::string_view token);
std::string pointer_append(std::string_view pointer, std::size_t index);

/// Parses JSON text. On failure returns nullopt and appends errors: a syntax error (pointer "",
/// message with line and column) or duplicate keys (pointer of the duplicate key).
std::optional<nlohmann::json> parse_json(std::string_view text, std::vector<SpecError>* errors);

/// Deepest nesting parse_json accepts: far deeper than any study or manifest needs (about 6
/// levels), far shallower than a thread's stack can hold (the parser and the validator recurse
/// once per level, so a body of a million '[' would otherwise crash the process).
inline constexpr std::size_t kMaxJsonDepth = 64;
/// Deepest nesting of arrays and objects in JSON text (strings skipped); stops counting once it
/// exceeds stop_at. A linear scan, safe on any input.
std::size_t json_nesting_depth(std::string_view text, std::size_t stop_at = kMaxJsonDepth);

/// A compiled schema, reusable for many documents. Local "$ref"s ("#/$defs/...") only.
class SchemaValidator {
 public:
  /// Throws std::invalid_argument if the schema itself cannot be compiled.
  explicit SchemaValidator(nlohmann::json schema);
  ~SchemaValidator();
  SchemaValidator(SchemaValidator&&) noexcept;
  SchemaValidator& operator=(SchemaValidator&&) noexcept;

  /// Every schema violation of doc; empty when valid.
  std::vector<SpecError> validate(const nlohmann::json& doc) const;
  const nlohmann::json& schema() const noexcept { return schema_; }

 private:
  struct Compiled;
  nlohmann::json schema_;
  std::unique_ptr<Compiled> compiled_;
};

/// One-shot form of SchemaValidator(schema).validate(doc).
std::vector<SpecError> validate_against_schema(const nlohmann::json& doc,
                                               const nlohmann::json& schema);

}  // namespace stickslip::common
