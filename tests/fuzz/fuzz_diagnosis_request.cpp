// Fuzz target: the diagnosis request (diagnosis::parse_diagnosis_request on the document parsed
// by common::parse_json, as POST /v1/diagnoses does): the request schema, the options and the
// dataset with its CSV texts. The input is the JSON text. No diagnosis is run.
// Properties: nothing is thrown; a rejected request names at least one error, each with a JSON
// Pointer; an accepted one has valid options (DiagnoseOptions::IsValid) and at least one run.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_support.h"
#include "stickslip/common/json_schema.h"
#include "stickslip/diagnosis/diagnosis_request.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace stickslip;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  if (common::json_nesting_depth(text) > common::kMaxJsonDepth) return 0;  // the server's 400
  std::vector<common::SpecError> errors;
  const auto doc = common::parse_json(text, &errors);
  if (!doc) {
    FUZZ_CHECK(!errors.empty(), "malformed JSON without an error");
    return 0;
  }
  const diagnosis::ParsedDiagnosisRequest r = diagnosis::parse_diagnosis_request(*doc, 1);
  if (!r.ok()) {
    FUZZ_CHECK(!r.errors.empty(), "rejected without an error");
    for (const auto& e : r.errors)
      FUZZ_CHECK(e.pointer.empty() || e.pointer.front() == '/', e.pointer);
    return 0;
  }
  std::string why;
  FUZZ_CHECK(r.request->options.IsValid(&why), why);
  FUZZ_CHECK(!r.request->data.runs.empty(), "accepted without runs");
  return 0;
}
