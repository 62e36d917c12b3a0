// JSON Schema checking (json_schema.h): every error reported, each with a JSON Pointer and a
// readable message.
#include "stickslip/common/json_schema.h"

#include <gtest/gtest.h>

#include "support/spec_errors.h"

namespace stickslip::common {
namespace {

using json = nlohmann::json;

TEST(JsonSchema, ReportsEveryErrorWithPointers) {
  const json schema = json::parse(R"({
    "type": "object", "additionalProperties": false, "required": ["id"],
    "properties": {
      "id": {"type": "integer", "minimum": 1},
      "tags": {"type": "array", "items": {"type": "string"}, "maxItems": 2},
      "inner": {"$ref": "#/$defs/inner"}
    },
    "$defs": {"inner": {"type": "object", "additionalProperties": false,
                        "properties": {"x": {"enum": ["a", "b"]}}}}
  })");
  const auto ok = validate_against_schema(json::parse(R"({"id": 3, "inner": {"x": "a"}})"), schema);
  EXPECT_TRUE(ok.empty()) << to_string(ok);
  const auto errors = validate_against_schema(
      json::parse(R"({"id": 0, "p": 1, "q": 2, "tags": ["a", 5, "c"], "inner": {"x": "z", "y": 1}})"),
      schema);
  EXPECT_ERROR(errors, "/p", "unknown field \"p\"");
  EXPECT_ERROR(errors, "/q", "unknown field \"q\"");
  EXPECT_ERROR(errors, "/inner/y", "unknown field \"y\" (allowed: x)");
  EXPECT_ERROR(errors, "/id", "must be >= 1, got 0");
  EXPECT_ERROR(errors, "/tags/1", "expected string, got integer");
  EXPECT_ERROR(errors, "/tags", "expected at most 2 strings, got 3");
  EXPECT_ERROR(errors, "/inner/x", "must be one of \"a\", \"b\"; got \"z\"");
  EXPECT_EQ(errors.size(), 7u) << to_string(errors);
  const auto missing = validate_against_schema(json::object(), schema);
  ASSERT_EQ(missing.size(), 1u);
  EXPECT_EQ(missing[0], (SpecError{"", "missing required field \"id\""}));
}

TEST(JsonSchema, PointerEscaping) {
  EXPECT_EQ(pointer_append("/a", "b/c~d"), "/a/b~1c~0d");
  EXPECT_EQ(pointer_append("", std::size_t{3}), "/3");
  const json schema = json::parse(R"({"type": "object", "additionalProperties": false})");
  const auto errors = validate_against_schema(json::parse(R"({"a/b": 1})"), schema);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].pointer, "/a~1b");
}

}  // namespace
}  // namespace stickslip::common
