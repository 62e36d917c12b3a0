#pragma once
// The end-to-end tests' stickslipd and curl: a daemon on an ephemeral port (its log files in the
// test's directory), and curl returning status, body and headers. Shared by test_e2e.cpp and
// test_e2e_diagnoses.cpp.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "process.h"

namespace stickslip::server::testing {

inline const std::string kServerBin = std::string(STICKSLIP_BINARY_DIR) + "/server/stickslipd";
inline const std::string kClientBin = std::string(STICKSLIP_BINARY_DIR) + "/client/stickslip";

/// A running stickslipd over dir/e2e.db on an ephemeral port (--port-file), with extra options
/// and environment entries ("NAME=value").
class Daemon {
 public:
  explicit Daemon(const std::filesystem::path& dir, const std::vector<std::string>& extra = {},
                  const std::vector<std::string>& env = {}) {
    using namespace std::chrono_literals;
    const std::filesystem::path port_file = dir / "port";
    std::filesystem::remove(port_file);
    std::vector<std::string> argv = {kServerBin, "--db", (dir / "e2e.db").string(), "--port", "0",
                                     "--port-file", port_file.string(), "--threads", "2"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    static int n = 0;
    proc_ = std::make_unique<Process>(argv, (dir / ("daemon" + std::to_string(n++))).string(), env);
    for (int i = 0; i < 1000 && !std::filesystem::exists(port_file); ++i) {
      if (proc_->wait(0ms)) break;
      std::this_thread::sleep_for(10ms);
    }
    if (!std::filesystem::exists(port_file))
      throw std::runtime_error("stickslipd did not start: " + proc_->err());
    url_ = "http://127.0.0.1:" + std::to_string(std::stoi(slurp(port_file)));
  }
  const std::string& url() const { return url_; }
  Process& process() { return *proc_; }

 private:
  std::unique_ptr<Process> proc_;
  std::string url_;
};

/// A study spec of 2 models (dahl, lugre) x n_va values of va_over_vd in [0, 4], two stages of
/// `duration` s each (the second with 1500 Hz vibration; adaptive integrator).
inline std::string study_json(const std::string& name, int n_va, double duration) {
  return nlohmann::json(
             {{"name", name},
              {"stages", {{{"duration", duration}}, {{"duration", duration}, {"f", 1500}}}},
              {"design",
               {{"type", "grid"},
                {"axes",
                 {{{"name", "model"}, {"values", {"dahl", "lugre"}}},
                  {{"name", "va_over_vd"}, {"linspace", {0, 4, n_va}}}}}}}})
      .dump(2);
}

struct Curl {
  int status = 0;
  std::string body, headers;
};

/// curl -sS with args, run in dir; expects curl itself to succeed.
inline Curl curl(const std::filesystem::path& dir, const std::vector<std::string>& args) {
  const std::filesystem::path body = dir / "curl.body", headers = dir / "curl.headers";
  std::vector<std::string> argv = {"curl", "-sS", "-o", body.string(), "-D", headers.string(),
                                   "-w", "%{http_code}"};
  argv.insert(argv.end(), args.begin(), args.end());
  const CommandResult r = run_command(argv, dir);
  EXPECT_EQ(r.code, 0) << r.err;
  Curl c;
  c.status = std::atoi(r.out.c_str());
  c.body = slurp(body);
  c.headers = slurp(headers);
  return c;
}

}  // namespace stickslip::server::testing
