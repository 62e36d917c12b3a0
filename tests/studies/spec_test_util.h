#pragma once
// Helpers of the study-spec tests (test_spec.cpp, test_spec_errors.cpp): parse a spec that must
// be valid or must fail, a small valid study to break, a sampled design over three ranges.
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "stickslip/studies/spec.h"
#include "support/spec_errors.h"

namespace stickslip::studies::spec_test {

using json = nlohmann::json;

inline std::string read_text(const std::string& relative) {
  std::ifstream in(std::string(STICKSLIP_SOURCE_DIR) + "/" + relative);
  EXPECT_TRUE(in.good()) << relative;
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

inline StudySpec parse_ok(const std::string& text, const Limits& limits = {}) {
  auto r = parse_study(text, limits);
  EXPECT_TRUE(r.errors.empty()) << to_string(r.errors);
  if (!r.spec) throw std::runtime_error("spec did not parse: " + to_string(r.errors));
  return std::move(*r.spec);
}

inline StudySpec parse_ok(const json& doc) { return parse_ok(doc.dump()); }

inline std::vector<common::SpecError> errors_of(const std::string& text, const Limits& limits = {}) {
  auto r = parse_study(text, limits);
  EXPECT_FALSE(r.spec.has_value()) << "expected errors for " << text;
  return r.errors;
}

inline std::vector<common::SpecError> errors_of(const char* text, const Limits& limits = {}) {
  return errors_of(std::string(text), limits);
}

inline std::vector<common::SpecError> errors_of(const json& doc, const Limits& limits = {}) {
  return errors_of(doc.dump(), limits);
}

// A small valid engine study to break one field at a time.
inline json valid_doc() {
  return json::parse(R"({
    "name": "t",
    "design": {"type": "grid", "axes": [
      {"name": "model", "values": ["dahl", "lugre"]},
      {"name": "k_d", "values": [5000, 11700]}]}
  })");
}

inline json sampled(const std::string& type, std::uint64_t seed, std::size_t n = 0) {
  json d = {{"type", type}, {"seed", seed},
            {"ranges", json::array({{{"name", "F_S"}, {"min", 9}, {"max", 13}},
                                    {{"name", "k_d"}, {"min", 1e3}, {"max", 1e5},
                                     {"scale", "log"}},
                                    {{"name", "va_over_vd"}, {"min", 0}, {"max", 2}}})}};
  if (type == "morris")
    d["trajectories"] = n;
  else
    d["n"] = n;
  return {{"name", "s"}, {"design", d}};
}

inline std::vector<std::string> all_points(const StudySpec& spec) {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < spec.run_count(); ++i)
    out.push_back(spec.canonical_point_json(spec.point(i)));
  return out;
}

}  // namespace stickslip::studies::spec_test
