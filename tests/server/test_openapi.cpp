// The OpenAPI document parses, documents exactly the routes the server serves, and every local
// $ref in it resolves.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <fstream>
#include <sstream>

#include "stickslip/server/api.h"
#include "test_support.h"

namespace stickslip::server {
namespace {

using nlohmann::json;

void collect_refs(const json& j, std::vector<std::string>* refs) {
  if (j.is_object()) {
    for (const auto& [k, v] : j.items()) {
      if (k == "$ref" && v.is_string()) refs->push_back(v.get<std::string>());
      collect_refs(v, refs);
    }
  } else if (j.is_array()) {
    for (const auto& v : j) collect_refs(v, refs);
  }
}

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

TEST(OpenApi, ServedDocumentIsTheFileInSchemasAndParses) {
  std::ifstream in(std::string(STICKSLIP_SOURCE_DIR) + "/schemas/openapi.json");
  std::stringstream ss;
  ss << in.rdbuf();
  EXPECT_EQ(ss.str(), std::string(openapi_text()));
  const json doc = json::parse(openapi_text());
  EXPECT_EQ(doc["openapi"], "3.1.0");
  EXPECT_TRUE(doc["paths"].is_object());
}

TEST(OpenApi, EveryServedRouteIsDocumentedAndEveryDocumentedRouteIsServed) {
  testing::TempDir dir;
  ApiOptions o;
  o.db = dir / "o.db";
  Api api(o);
  const json doc = json::parse(openapi_text());
  for (const auto& route : api.router().routes()) {
    ASSERT_TRUE(doc["paths"].contains(route.pattern)) << route.pattern;
    EXPECT_TRUE(doc["paths"][route.pattern].contains(lower(route.method)))
        << route.method << " " << route.pattern;
  }
  for (const auto& [path, ops] : doc["paths"].items()) {
    for (const auto& [method, op] : ops.items()) {
      const bool served = std::any_of(
          api.router().routes().begin(), api.router().routes().end(),
          [&](const Route& r) { return r.pattern == path && lower(r.method) == method; });
      EXPECT_TRUE(served) << method << " " << path << " is documented but not served";
      EXPECT_TRUE(op.contains("operationId")) << method << " " << path;
      EXPECT_TRUE(op.contains("responses")) << method << " " << path;
    }
  }
  // The document served over HTTP is the same, and so is the study schema it references.
  const Response r = api.handle(testing::get("/v1/openapi.json"));
  ASSERT_EQ(r.status, 200);
  EXPECT_EQ(json::parse(r.body), doc);
  const Response schema = api.handle(testing::get("/v1/study.schema.json"));
  ASSERT_EQ(schema.status, 200);
  EXPECT_EQ(json::parse(schema.body)["$schema"], "https://json-schema.org/draft/2020-12/schema");
  const Response diag = api.handle(testing::get("/v1/diagnosis_request.schema.json"));
  ASSERT_EQ(diag.status, 200);
  EXPECT_EQ(json::parse(diag.body)["required"], json({"manifest", "files"}));
  const Response result = api.handle(testing::get("/v1/diagnosis.schema.json"));
  ASSERT_EQ(result.status, 200);
  EXPECT_EQ(json::parse(result.body)["title"], "stickslip diagnosis");
  const Response vreq = api.handle(testing::get("/v1/validation_request.schema.json"));
  ASSERT_EQ(vreq.status, 200);
  EXPECT_EQ(json::parse(vreq.body)["required"], json({"manifest", "files"}));
  const Response val = api.handle(testing::get("/v1/validation.schema.json"));
  ASSERT_EQ(val.status, 200);
  EXPECT_EQ(json::parse(val.body)["title"], "stickslip validation");
  // The served validation schema carries the definitions it shares with the diagnosis schema.
  EXPECT_TRUE(json::parse(val.body)["$defs"].contains("slipstats"));
}

TEST(OpenApi, EveryLocalReferenceResolves) {
  const json doc = json::parse(openapi_text());
  std::vector<std::string> refs;
  collect_refs(doc, &refs);
  ASSERT_FALSE(refs.empty());
  for (const auto& ref : refs) {
    // Served at /v1/study.schema.json, /v1/diagnosis_request.schema.json,
    // /v1/diagnosis.schema.json, /v1/validation_request.schema.json and
    // /v1/validation.schema.json (tested above).
    if (ref == "study.schema.json" || ref == "diagnosis_request.schema.json" ||
        ref == "diagnosis.schema.json" || ref == "validation_request.schema.json" ||
        ref == "validation.schema.json")
      continue;
    ASSERT_TRUE(ref.starts_with("#/")) << ref;
    EXPECT_TRUE(doc.contains(json::json_pointer(ref.substr(1)))) << ref;
  }
}

}  // namespace
}  // namespace stickslip::server
