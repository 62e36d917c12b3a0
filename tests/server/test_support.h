#pragma once
// Shared helpers of the server tests: temporary directories, request builders, tiny studies.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "stickslip/server/http.h"
#include "support/temp_dir.h"

namespace stickslip::server::testing {

/// The shared temporary directory of the test suites (tests/support/temp_dir.h).
using TempDir = ::stickslip::testing::TempDir;

inline Request get(std::string target, std::vector<Header> headers = {}) {
  return Request{"GET", std::move(target), std::move(headers), ""};
}

inline Request post_json(std::string target, std::string body, std::vector<Header> headers = {}) {
  headers.push_back({"Content-Type", "application/json"});
  return Request{"POST", std::move(target), std::move(headers), std::move(body)};
}

inline nlohmann::json body_json(const Response& r) { return nlohmann::json::parse(r.body); }

/// A tiny valid study: 2 models x 2 va_over_vd, two 0.5 s stages, fixed-step RK4.
inline std::string tiny_study(const std::string& name = "tiny") {
  return R"({"name": ")" + name + R"(",
    "stages": [{"duration": 0.5}, {"duration": 0.5, "v_a": 0, "f": 1500}],
    "integrator": {"kind": "rk4", "dt": 1e-5},
    "design": {"type": "grid", "axes": [
      {"name": "model", "values": ["dahl", "lugre"]},
      {"name": "va_over_vd", "values": [0, 2]}]}})";
}

}  // namespace stickslip::server::testing
