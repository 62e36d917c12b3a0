#pragma once
// Checks on lists of JSON errors (common::SpecError), shared by the tests of the JSON Schema
// checking (tests/common) and of the study spec (tests/studies).
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "stickslip/common/json_schema.h"

namespace stickslip::testing {

// The error at 'pointer' whose message contains 'text', if any.
inline bool has_error(const std::vector<common::SpecError>& errors, const std::string& pointer,
                      const std::string& text) {
  return std::any_of(errors.begin(), errors.end(), [&](const common::SpecError& e) {
    return e.pointer == pointer && e.message.find(text) != std::string::npos;
  });
}

}  // namespace stickslip::testing

#define EXPECT_ERROR(errors, pointer, text)                                              \
  EXPECT_TRUE(::stickslip::testing::has_error(errors, pointer, text))                    \
      << "wanted " << pointer << ": " << text << "\ngot:\n"                              \
      << ::stickslip::common::to_string(errors)
