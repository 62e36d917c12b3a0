// One source for the bounds of the options a diagnosis request may set: the request schema. The
// schema allowed max_evals_base = 1 where the diagnosis required >= 10 (issue 18, defect 6), so
// a client that trusted the published schema got a 422 from the server anyway.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "stickslip/common/json_schema.h"
#include "stickslip/diagnosis/diagnose.h"
#include "stickslip/diagnosis/diagnosis_request.h"

namespace {

using namespace stickslip;
using nlohmann::json;

bool schema_flags(const std::string& option, int value) {
  static const common::SchemaValidator v(json::parse(diagnosis::diagnosis_request_schema_text()));
  for (const auto& e : v.validate(json{{"options", {{option, value}}}}))
    if (e.pointer == "/options/" + option) return true;
  return false;
}

TEST(DiagnosisRequestLimits, TheSchemaAndTheDiagnosisAgreeOnEveryIntegerOption) {
  struct Case {
    const char* name;
    int diagnosis::DiagnoseOptions::*field;
  };
  for (const Case c : {Case{"max_evals_base", &diagnosis::DiagnoseOptions::max_evals_base},
                       Case{"max_evals_candidate", &diagnosis::DiagnoseOptions::max_evals_candidate},
                       Case{"max_evals_fold", &diagnosis::DiagnoseOptions::max_evals_fold}}) {
    SCOPED_TRACE(c.name);
    const int min = diagnosis::option_minimum(c.name);
    diagnosis::DiagnoseOptions o;
    std::string why;
    o.*c.field = min;
    EXPECT_TRUE(o.IsValid(&why)) << why;
    EXPECT_FALSE(schema_flags(c.name, min));
    o.*c.field = min - 1;
    EXPECT_FALSE(o.IsValid(&why));
    EXPECT_NE(why.find(std::string(c.name) + " = " + std::to_string(min - 1)), std::string::npos)
        << why;
    EXPECT_TRUE(schema_flags(c.name, min - 1)) << "the schema accepts what the diagnosis refuses";
  }
  EXPECT_EQ(diagnosis::option_minimum("max_evals_base"), 10);
}

}  // namespace
