// `stickslip validate DIAGNOSIS.json MANIFEST --server URL [--wait] [--out DIR]` (validate_remote.h).
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "diagnose_remote.h"
#include "stickslip/client/cli.h"
#include "stickslip/client/remote.h"
#include "stickslip/common/json_schema.h"
#include "stickslip/measured/measured.h"
#include "validate_remote.h"

namespace stickslip::client {

using nlohmann::json;
namespace fs = std::filesystem;

namespace {

const std::string kCollection = "/v1/validations";

json read_json(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::invalid_argument("cannot read diagnosis \"" + path + "\"");
  std::ostringstream ss;
  ss << in.rdbuf();
  std::vector<common::SpecError> errors;
  auto doc = common::parse_json(ss.str(), &errors);
  if (!doc) throw std::invalid_argument(path + ": " + common::to_string(errors));
  return *doc;
}

void print_validation(const json& v) {
  std::cout << v.value("id", "") << "  " << v.value("name", "") << "  " << v.value("state", "") << "\n";
  if (v["error"].is_string()) std::cout << "  error: " << v["error"].get<std::string>() << "\n";
  const json& r = v.value("result", json());
  if (!r.is_object()) return;
  for (const auto& run : r.value("runs", json::array()))
    for (const auto& st : run.value("stages", json::array()))
      std::cout << "  " << run.value("run", "") << " stage " << st.value("stage", 0) << ": "
                << (st.value("reproduced", false) ? "reproduced" : "not reproduced") << "\n";
}

/// DIR/validation.json and every run's CSV (from the stored series).
void write_outputs(Remote& remote, const json& v, const std::string& out, bool quiet) {
  if (out.empty() || !v["result"].is_object()) return;
  fs::create_directories(out);
  const fs::path file = fs::path(out) / "validation.json";
  std::ofstream f(file);
  f << v["result"].dump(2) << "\n";
  if (!f.flush()) throw std::runtime_error("cannot write " + file.string());
  if (!quiet) std::cout << "wrote " << file.string() << "\n";
  const json& runs = v["result"].value("runs", json::array());
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const fs::path csv = fs::path(out) / runs[k].value("csv", "run" + std::to_string(k) + ".csv");
    std::ofstream c(csv);
    c << remote.get_text(kCollection + "/" + v.value("id", "") + "/traces/" + std::to_string(k) + "?format=csv");
    if (!c.flush()) throw std::runtime_error("cannot write " + csv.string());
    if (!quiet) std::cout << "wrote " << csv.string() << "\n";
  }
}

}  // namespace

int remote_validate(const RemoteValidateArgs& a) {
  return guarded_remote([&]() -> int {
    measured::load_measured(a.manifest);  // the local checks first: they name local files
    json request = diagnosis_request_from_files(a.manifest, json::object());
    request["diagnosis"] = read_json(a.diagnosis);
    Remote remote = make_remote(a.server);
    const json v = remote.submit_job(kCollection, request.dump(), a.idempotency_key);
    const std::string id = v.value("id", "");
    if (!a.wait) {
      if (a.json_output) std::cout << v.dump(2) << "\n";
      else std::cout << id << "\n";
      return kOk;
    }
    if (!a.json_output) std::cout << id << "\n" << std::flush;
    const json d = remote.wait_job(kCollection, id, 1.0, [&](const json& s) {
      if (a.quiet) return;
      std::cerr << id << ": " << s.value("state", "");
      if (s.contains("progress") && s["progress"].is_object())
        std::cerr << " " << s["progress"].value("phase", "") << " " << s["progress"].value("item", "");
      std::cerr << "\n";
    });
    if (a.json_output) std::cout << d.dump(2) << "\n";
    else print_validation(d);
    write_outputs(remote, d, a.out, a.json_output);
    return d.value("state", "") == "succeeded" ? kOk : kStudyFailed;
  });
}

}  // namespace stickslip::client
