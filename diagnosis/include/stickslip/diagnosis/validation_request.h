#pragma once
// A validation sent as one JSON document (schemas/validation_request.schema.json), the body of
// the server's POST /v1/validations:
//
//   {"diagnosis": {...diagnosis.json...} | "diagnosis_id": "dg-...",
//    "manifest": {...measured manifest...}, "files": {"run.csv": "t,Fd\n...", ...},
//    "options": {"rtol": 1e-7}}
//
// Checked in order, every problem with a JSON pointer into the document: the request schema, the
// diagnosis' calibrated models (at /diagnosis/models: each model builds, every parameter is
// known and allowed), then the dataset (measured.h, load_measured from memory). A diagnosis_id is
// resolved by the server's worker (the stored diagnosis' result).

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "stickslip/common/json_schema.h"
#include "stickslip/diagnosis/validate.h"
#include "stickslip/measured/measured.h"

namespace stickslip::diagnosis {

struct ValidationRequest {
  std::optional<nlohmann::json> diagnosis;  ///< the document, or
  std::string diagnosis_id;                 ///< the stored diagnosis to read it from
  measured::MeasuredDataset data;
  ValidateOptions options;
};

struct ParsedValidationRequest {
  std::optional<ValidationRequest> request;
  std::vector<common::SpecError> errors;
  bool ok() const noexcept { return request.has_value(); }
};

/// Validates and loads a parsed request document. Never throws for a bad document; threads sets
/// ValidateOptions::threads (not settable by a request).
ParsedValidationRequest parse_validation_request(const nlohmann::json& doc, int threads = 0);

/// The errors of a diagnosis document's models (pointers under `at`); empty when usable.
std::vector<common::SpecError> check_diagnosis_models(const nlohmann::json& diagnosis, const std::string& at);

std::string_view validation_request_schema_text() noexcept;

}  // namespace stickslip::diagnosis
