#pragma once
// Small text helpers shared by the libraries above the engine.
#include <string>
#include <string_view>
#include <vector>

namespace stickslip::common {

/// parts joined with sep between them ("" for no parts), e.g. the messages of an IsValid:
/// join(errors, "; ").
std::string join(const std::vector<std::string>& parts, std::string_view sep);

}  // namespace stickslip::common
