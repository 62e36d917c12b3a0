// Fuzz target: the measured-data manifest and CSV reader (measured::load_measured on a manifest
// and CSV texts in memory: what POST /v1/diagnoses checks, with the same CSV reader as
// `stickslip diagnose` on files). The input is parts separated by NUL bytes: the manifest JSON,
// then the CSV texts, given to the manifest's runs' `file` names in order (when the manifest is
// not JSON, a fixed two-run manifest naming a.csv and b.csv reads them, so the CSV reader is
// reached whatever the first part is).
// Properties: only MeasuredError is thrown, with at least one error, each with a JSON Pointer
// under /manifest or /files; a loaded dataset has every run with at least kMinMeasuredSamples
// samples, t strictly increasing and finite, and Fd finite.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <map>
#include <string>

#include "fuzz_support.h"
#include "stickslip/common/json_schema.h"
#include "stickslip/measured/measured.h"

namespace {
const char* kDefaultManifest = R"({"name": "fuzz", "runs": [
  {"name": "a", "file": "a.csv", "conditions": {"t_on": 1, "duration": 2}},
  {"name": "b", "file": "b.csv", "conditions": {"va": 0.001, "t_on": 0, "duration": 2}}]})";
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace stickslip;
  const auto parts =
      fuzz::split_parts(std::string_view(reinterpret_cast<const char*>(data), size), 5);
  std::vector<common::SpecError> json_errors;
  auto manifest = common::parse_json(parts[0], &json_errors);
  if (!manifest) manifest = nlohmann::json::parse(kDefaultManifest);
  std::vector<std::string> names;
  if (manifest->is_object() && manifest->contains("runs") && (*manifest)["runs"].is_array())
    for (const auto& run : (*manifest)["runs"])
      if (run.is_object() && run.contains("file") && run["file"].is_string())
        names.push_back(run["file"].get<std::string>());
  std::map<std::string, std::string> files;
  for (std::size_t i = 1; i < parts.size(); ++i)
    files[i - 1 < names.size() ? names[i - 1] : "extra" + std::to_string(i) + ".csv"] =
        std::string(parts[i]);
  try {
    const measured::MeasuredDataset ds = measured::load_measured(*manifest, files);
    FUZZ_CHECK(!ds.runs.empty(), "a dataset without runs");
    for (const auto& run : ds.runs) {
      FUZZ_CHECK(run.t.size() == run.Fd.size(), run.name);
      FUZZ_CHECK(run.t.size() >= measured::kMinMeasuredSamples, run.name);
      for (std::size_t k = 0; k < run.t.size(); ++k) {
        FUZZ_CHECK(std::isfinite(run.t[k]) && std::isfinite(run.Fd[k]), run.name);
        if (k > 0) FUZZ_CHECK(run.t[k] > run.t[k - 1], run.name);
      }
    }
  } catch (const measured::MeasuredError& e) {
    FUZZ_CHECK(!e.errors().empty(), "MeasuredError without errors");
    for (const auto& err : e.errors())
      FUZZ_CHECK(err.pointer.starts_with("/manifest") || err.pointer.starts_with("/files"),
                 err.pointer + ": " + err.message);
  }
  return 0;
}
