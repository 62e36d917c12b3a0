#pragma once
#include <stdexcept>
#include <string>

namespace stickslip::engine {

/// Error for a bad user-supplied value. what() is "field = value: why".
class InvalidParameter : public std::invalid_argument {
 public:
  InvalidParameter(std::string field, double value, const std::string& why);
  InvalidParameter(std::string field, const std::string& value, const std::string& why);
  const std::string& field() const noexcept { return field_; }

 private:
  std::string field_;
};

}  // namespace stickslip::engine
