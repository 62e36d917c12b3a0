#pragma once
// Shared helpers of the server tests: temporary directories, request builders, tiny studies.
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <random>
#include <string>

#include <nlohmann/json.hpp>

#include "stickslip/server/http.h"

namespace stickslip::server::testing {

namespace fs = std::filesystem;

/// A fresh directory under the system temp dir, removed on destruction.
class TempDir {
 public:
  TempDir() {
    static std::atomic<int> counter{0};
    std::random_device rd;
    path_ = fs::temp_directory_path() /
            ("stickslip-server-" + std::to_string(::getpid()) + "-" +
             std::to_string(counter.fetch_add(1)) + "-" + std::to_string(rd()));
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const fs::path& path() const { return path_; }
  fs::path operator/(const std::string& name) const { return path_ / name; }

 private:
  fs::path path_;
};

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
