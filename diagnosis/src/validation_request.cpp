// The validation request document (validation_request.h).
#include "stickslip/diagnosis/validation_request.h"

#include <map>

#include "stickslip/diagnosis/validation_request_schema_data.h"

namespace stickslip::diagnosis {

using nlohmann::json;

std::string_view validation_request_schema_text() noexcept {
  return generated::kValidationRequestSchemaJson;
}

std::vector<common::SpecError> check_diagnosis_models(const json& diagnosis, const std::string& at) {
  std::vector<common::SpecError> errors;
  if (!diagnosis.is_object() || !diagnosis.contains("models") || !diagnosis["models"].is_object()) {
    errors.push_back({at + "/models", "the diagnosis has no calibrated models (\"models\")"});
    return errors;
  }
  for (const char* side : {"base", "extended"}) {
    const std::string ptr = at + "/models/" + side;
    try {
      const CalibratedModel m = calibrated_from_json(diagnosis["models"].at(side));
      engine::SimConfig c = engine::SimConfig::seed(m.model, 0.0);
      c.extension.kind = m.effect;
      for (const auto& [name, value] : m.params) engine::set_parameter(c, name, value);
      std::vector<std::string> why;
      if (!c.IsValid(&why)) errors.push_back({ptr, why.front()});
    } catch (const std::exception& e) {
      errors.push_back({ptr, e.what()});
    }
  }
  return errors;
}

ParsedValidationRequest parse_validation_request(const json& doc, int threads) {
  static const common::SchemaValidator validator(json::parse(generated::kValidationRequestSchemaJson));
  ParsedValidationRequest out;
  out.errors = validator.validate(doc);
  if (!out.errors.empty()) return out;
  ValidationRequest r;
  r.options.threads = threads;
  if (doc.contains("diagnosis")) {
    r.diagnosis = doc["diagnosis"];
    const auto e = check_diagnosis_models(doc["diagnosis"], "/diagnosis");
    out.errors.insert(out.errors.end(), e.begin(), e.end());
  } else {
    r.diagnosis_id = doc["diagnosis_id"].get<std::string>();
  }
  if (doc.contains("options") && doc["options"].contains("rtol")) r.options.rtol = doc["options"]["rtol"].get<double>();
  std::map<std::string, std::string> files;
  for (const auto& [name, text] : doc["files"].items()) files[name] = text.get<std::string>();
  try {
    r.data = measured::load_measured(doc["manifest"], files);
  } catch (const measured::MeasuredError& e) {
    out.errors.insert(out.errors.end(), e.errors().begin(), e.errors().end());
  }
  if (out.errors.empty()) out.request = std::move(r);
  return out;
}

}  // namespace stickslip::diagnosis
