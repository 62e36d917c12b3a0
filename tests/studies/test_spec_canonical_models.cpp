// The canonical form of a study spec (the text a stored study is resumed by, through its hash)
// under a growing model registry: it carries the parameters and options of the models the study
// uses and those of the seed's four models (ModelTraits::in_every_canonical_spec), so that
// registering a model changes no stored study's canonical text or hash.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <set>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "stickslip/engine/registry.h"
#include "stickslip/store/store.h"
#include "studies/spec_test_util.h"

namespace stickslip::studies {
namespace {

using json = nlohmann::json;
using spec_test::parse_ok;
using spec_test::read_text;

/// (spec_json, spec_hash) of every study stored in a fixture database, opened read-only.
std::vector<std::pair<std::string, std::string>> stored_specs(const std::string& relative) {
  const std::string path = std::string(STICKSLIP_SOURCE_DIR) + "/" + relative;
  sqlite3* db = nullptr;
  std::vector<std::pair<std::string, std::string>> out;
  if (sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
    ADD_FAILURE() << "cannot open " << path;
    sqlite3_close(db);
    return out;
  }
  sqlite3_stmt* st = nullptr;
  if (sqlite3_prepare_v2(db, "SELECT spec_json, spec_hash FROM studies ORDER BY id", -1, &st,
                         nullptr) == SQLITE_OK) {
    while (sqlite3_step(st) == SQLITE_ROW)
      out.emplace_back(reinterpret_cast<const char*>(sqlite3_column_text(st, 0)),
                       reinterpret_cast<const char*>(sqlite3_column_text(st, 1)));
  }
  sqlite3_finalize(st);
  sqlite3_close(db);
  return out;
}

std::set<std::string> base_keys(const StudySpec& s) {
  std::set<std::string> out;
  for (const auto& [k, v] : s.canonical()["base"].items()) out.insert(k);
  return out;
}

// The studies stored by earlier builds (tests/data/store_v1..v3.db, canonical forms written
// before any model beyond the seed's four existed) canonicalise to their stored text and hash,
// byte for byte: `study run` on their specs resumes them.
TEST(SpecCanonicalModels, StoredStudiesKeepTheirCanonicalTextAndHash) {
  int seen = 0;
  for (const char* db : {"tests/data/store_v1.db", "tests/data/store_v2.db",
                         "tests/data/store_v3.db"}) {
    for (const auto& [text, hash] : stored_specs(db)) {
      SCOPED_TRACE(std::string(db) + ": " + text);
      const StudySpec s = parse_ok(text);
      EXPECT_EQ(s.canonical_json(), text);
      EXPECT_EQ(store::param_hash(s.canonical_json()), hash);
      ++seen;
    }
  }
  EXPECT_GE(seen, 4);
}

// A spec that uses none of the other models carries exactly the seed models' parameters (the
// base of the shipped paper map and of the stored fixtures); one that uses a model, as its base
// model or in its design, carries that model's parameters and options too.
TEST(SpecCanonicalModels, CarriesTheParametersOfTheModelsItUses) {
  const auto stored = stored_specs("tests/data/store_v3.db");
  ASSERT_FALSE(stored.empty());
  const std::set<std::string> legacy = base_keys(parse_ok(stored.front().first));
  EXPECT_EQ(base_keys(parse_ok(read_text("studies/paper-map.json"))), legacy);

  std::set<std::string> seed_params;
  for (const engine::ModelTraits& t : engine::all_model_traits()) {
    if (!t.in_every_canonical_spec) continue;
    for (const engine::ParamDef& p : t.params) seed_params.insert(p.name);
  }
  for (const std::string& p : seed_params) EXPECT_TRUE(legacy.count(p)) << p;

  for (const engine::ModelTraits& t : engine::all_model_traits()) {
    if (t.in_every_canonical_spec) continue;
    SCOPED_TRACE(t.info->name);
    for (const engine::ParamDef& p : t.params) {
      if (!seed_params.count(p.name)) {
        EXPECT_FALSE(legacy.count(p.name)) << p.name;
      }
    }
    for (const engine::OptionDef& o : t.options) {
      EXPECT_FALSE(legacy.count(o.name)) << o.name;
    }
    // used as the base model, and only named in a grid's model axis
    const json as_base = {{"name", "x"},
                          {"base", {{"model", t.info->name}}},
                          {"design", {{"type", "list"}, {"points", json::array({json::object()})}}}};
    const json in_design = {
        {"name", "x"},
        {"design",
         {{"type", "grid"},
          {"axes", json::array({{{"name", "model"}, {"values", {"lugre", t.info->name}}}})}}}};
    for (const json& doc : {as_base, in_design}) {
      const std::set<std::string> keys = base_keys(parse_ok(doc));
      for (const engine::ParamDef& p : t.params) EXPECT_TRUE(keys.count(p.name)) << p.name;
      for (const engine::OptionDef& o : t.options) EXPECT_TRUE(keys.count(o.name)) << o.name;
      for (const std::string& k : legacy) EXPECT_TRUE(keys.count(k)) << k;
    }
  }
}

}  // namespace
}  // namespace stickslip::studies
