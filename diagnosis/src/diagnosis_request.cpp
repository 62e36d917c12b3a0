// The diagnosis request document (diagnosis_request.h): schema, options, dataset.
#include "stickslip/diagnosis/diagnosis_request.h"

#include <cctype>
#include <map>
#include <string>

#include "stickslip/diagnosis/diagnosis_request_schema_data.h"

namespace stickslip::diagnosis {
namespace {

using nlohmann::json;

const common::SchemaValidator& request_validator() {
  static const common::SchemaValidator validator(json::parse(generated::kDiagnosisRequestSchemaJson));
  return validator;
}

/// DiagnoseOptions::IsValid says "field = value: problem" or "field: problem"; the field
/// becomes the pointer /options/field.
std::string options_pointer(const std::string& why) {
  std::size_t n = 0;
  while (n < why.size() && (std::isalnum(static_cast<unsigned char>(why[n])) || why[n] == '_')) ++n;
  return n == 0 ? "/options" : "/options/" + why.substr(0, n);
}

}  // namespace

int option_minimum(const std::string& option) {
  static const json options = json::parse(generated::kDiagnosisRequestSchemaJson)
                                  .at("$defs")
                                  .at("options")
                                  .at("properties");
  return options.at(option).at("minimum").get<int>();
}

std::string_view diagnosis_request_schema_text() noexcept {
  return generated::kDiagnosisRequestSchemaJson;
}

ParsedDiagnosisRequest parse_diagnosis_request(const json& doc, int threads) {
  ParsedDiagnosisRequest out;
  out.errors = request_validator().validate(doc);
  if (!out.errors.empty()) return out;

  DiagnoseOptions o;
  o.keep_traces = false;  // series are for plots: the server's worker turns them on to store them
  o.threads = threads;
  if (const auto it = doc.find("options"); it != doc.end()) {
    const json& j = *it;
    if (j.contains("models")) {
      o.models.clear();
      for (const auto& m : j["models"]) o.models.push_back(engine::model_from_string(m.get<std::string>()));
    }
    if (j.contains("candidates")) {
      o.candidates.clear();
      for (const auto& c : j["candidates"])
        o.candidates.push_back(engine::extension_from_string(c.get<std::string>()));
    }
    for (auto [key, field] : {std::pair{"fit_rate", &o.fit_rate},
                              std::pair{"holdout_fraction", &o.holdout_fraction},
                              std::pair{"later_stage_fit_span", &o.later_stage_fit_span},
                              std::pair{"short_window", &o.short_window},
                              std::pair{"rtol", &o.rtol}, std::pair{"alpha", &o.alpha},
                              std::pair{"min_gain", &o.min_gain}})
      if (j.contains(key)) *field = j[key].get<double>();
    if (j.contains("max_evals_base")) o.max_evals_base = j["max_evals_base"].get<int>();
    if (j.contains("max_evals_candidate"))
      o.max_evals_candidate = j["max_evals_candidate"].get<int>();
    if (j.contains("fit_offset")) o.fit_offset = j["fit_offset"].get<bool>();
    if (j.contains("whole_run_holdout")) o.whole_run_holdout = j["whole_run_holdout"].get<bool>();
    if (j.contains("max_evals_fold")) o.max_evals_fold = j["max_evals_fold"].get<int>();
  }
  if (std::string why; !o.IsValid(&why)) out.errors.push_back({options_pointer(why), why});

  std::map<std::string, std::string> files;
  for (const auto& [name, text] : doc["files"].items()) files[name] = text.get<std::string>();
  try {
    measured::MeasuredDataset data = measured::load_measured(doc["manifest"], files);
    if (out.errors.empty()) out.request = DiagnosisRequest{std::move(data), o};
  } catch (const measured::MeasuredError& e) {
    out.errors.insert(out.errors.end(), e.errors().begin(), e.errors().end());
  }
  return out;
}

}  // namespace stickslip::diagnosis
