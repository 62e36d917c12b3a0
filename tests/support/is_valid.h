#pragma once
// Options::IsValid(&errors) with its messages joined by "; " into why, the form in which the
// tests read them (and the programs show them).
#include <string>
#include <vector>

#include "stickslip/common/text.h"

namespace stickslip::testing {

template <class Options>
bool is_valid(const Options& options, std::string& why) {
  std::vector<std::string> errors;
  const bool ok = options.IsValid(&errors);
  why = common::join(errors, "; ");
  return ok;
}

}  // namespace stickslip::testing
