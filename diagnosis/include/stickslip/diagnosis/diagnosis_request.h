#pragma once
// A diagnosis sent as one JSON document (schemas/diagnosis_request.schema.json), the body of
// the server's POST /v1/diagnoses and what the store keeps of it:
//
//   {"manifest": {...measured manifest...},
//    "files": {"va0.2.csv": "t,Fd\n0,0.1\n...", ...},
//    "options": {"models": ["lugre"], "candidates": ["viscous"], "max_evals_base": 20}}
//
// Checked in order, every problem with a JSON pointer into the document: the request schema,
// then the options (DiagnoseOptions::IsValid, at /options/<field>), then the dataset with the
// measured loader's own checks on the CSV texts (measured.h, load_measured from memory).

#include <optional>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "stickslip/diagnosis/diagnose.h"
#include "stickslip/common/json_schema.h"
#include "stickslip/measured/measured.h"

namespace stickslip::diagnosis {

/// The "minimum" of an integer option in schemas/diagnosis_request.schema.json ($defs/options):
/// the one place where those limits are written. DiagnoseOptions::IsValid enforces the same
/// numbers, so a request the schema accepts is never refused later for its options' bounds.
int option_minimum(const std::string& option);

struct DiagnosisRequest {
  measured::MeasuredDataset data;
  DiagnoseOptions options;  ///< defaults, overridden by the request's options; keep_traces off
};

struct ParsedDiagnosisRequest {
  std::optional<DiagnosisRequest> request;
  std::vector<common::SpecError> errors;
  bool ok() const noexcept { return request.has_value(); }
};

/// Validates and loads a parsed request document (see the header comment). Never throws for a
/// bad document; threads sets DiagnoseOptions::threads (not settable by a request).
ParsedDiagnosisRequest parse_diagnosis_request(const nlohmann::json& doc, int threads = 0);

/// schemas/diagnosis_request.schema.json, embedded at build time.
std::string_view diagnosis_request_schema_text() noexcept;

}  // namespace stickslip::diagnosis
