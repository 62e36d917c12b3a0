// The JSON text side of json_schema.h: parsing JSON text (syntax errors with their place,
// duplicate keys, the nesting limit), JSON Pointers and the error list's text form. The schema
// checking is in json_schema.cpp; the two share nothing.
#include <algorithm>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "stickslip/common/json_schema.h"

namespace stickslip::common {
namespace {
using json = nlohmann::json;
}  // namespace

std::string to_string(const SpecError& error) {
  return error.pointer.empty() ? error.message : error.pointer + ": " + error.message;
}

std::string to_string(const std::vector<SpecError>& errors) {
  std::string out;
  for (const auto& e : errors) out += to_string(e) + "\n";
  return out;
}

std::string pointer_append(std::string_view pointer, std::string_view token) {
  std::string out(pointer);
  out += '/';
  for (char c : token) {
    if (c == '~') {
      out += "~0";
    } else if (c == '/') {
      out += "~1";
    } else {
      out += c;
    }
  }
  return out;
}

std::string pointer_append(std::string_view pointer, std::size_t index) {
  return pointer_append(pointer, std::to_string(index));
}

std::size_t json_nesting_depth(std::string_view text, std::size_t stop_at) {
  std::size_t depth = 0, deepest = 0;
  bool in_string = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\') ++i;
      else if (c == '"') in_string = false;
      continue;
    }
    if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      deepest = std::max(deepest, ++depth);
      if (deepest > stop_at) return deepest;
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
  return deepest;
}

namespace {

/// A SAX pass that only looks for repeated keys, with the JSON Pointer of each. It builds no
/// document: the DOM comes from a plain json::parse. (nlohmann's callback parser, used for this
/// before, searches the enclosing array for discarded values at the end of every object, so an
/// array of n objects cost O(n^2): 100,001 list points took 3 s.)
class DuplicateKeyFinder {
 public:
  explicit DuplicateKeyFinder(std::vector<SpecError>* out) : out_(out) {}
  bool null() { return value(); }
  bool boolean(bool) { return value(); }
  bool number_integer(json::number_integer_t) { return value(); }
  bool number_unsigned(json::number_unsigned_t) { return value(); }
  bool number_float(json::number_float_t, const json::string_t&) { return value(); }
  bool string(json::string_t&) { return value(); }
  bool binary(json::binary_t&) { return value(); }
  bool start_object(std::size_t) { return push(true); }
  bool start_array(std::size_t) { return push(false); }
  bool end_object() { return pop(); }
  bool end_array() { return pop(); }
  bool key(json::string_t& key) {
    Frame& f = stack_.back();
    f.key = key;
    if (!f.keys.insert(key).second)
      out_->push_back({path(), "duplicate field \"" + key + "\" (each field may appear once)"});
    return true;
  }
  bool parse_error(std::size_t, const std::string&, const json::exception&) { return false; }

 private:
  struct Frame {
    bool is_object;
    std::set<std::string> keys;
    std::string key;
    std::size_t index = 0;
  };
  bool value() {
    if (!stack_.empty() && !stack_.back().is_object) ++stack_.back().index;
    return true;
  }
  bool push(bool is_object) {
    stack_.push_back({is_object, {}, {}, 0});
    return true;
  }
  bool pop() {
    stack_.pop_back();
    return value();
  }
  /// Pointer of the current key (only called on a duplicate, so its cost does not add up).
  std::string path() const {
    std::string p;
    for (const auto& f : stack_) p = f.is_object ? pointer_append(p, f.key) : pointer_append(p, f.index);
    return p;
  }
  std::vector<SpecError>* out_;
  std::vector<Frame> stack_;
};

}  // namespace

std::optional<nlohmann::json> parse_json(std::string_view text, std::vector<SpecError>* errors) {
  if (json_nesting_depth(text) > kMaxJsonDepth) {
    if (errors != nullptr)
      errors->push_back({"", "arrays and objects are nested more than " +
                                 std::to_string(kMaxJsonDepth) + " levels deep"});
    return std::nullopt;
  }
  try {
    json doc = json::parse(text.begin(), text.end());
    if (errors != nullptr) {
      DuplicateKeyFinder finder(errors);
      json::sax_parse(text.begin(), text.end(), &finder);
    }
    return doc;
  } catch (const json::exception& e) {
    std::string what = e.what();
    if (const auto close = what.find("] "); what.rfind("[json.exception", 0) == 0 &&
                                            close != std::string::npos)
      what = what.substr(close + 2);
    if (errors) errors->push_back({"", "malformed JSON: " + what});
    return std::nullopt;
  }
}

}  // namespace stickslip::common
